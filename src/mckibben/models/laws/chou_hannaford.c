/* The C face of chou_hannaford.py (Chou & Hannaford 1996, eq. 6): the same arithmetic as its
   kernel, theta row r at th[r]. Pa, m -> N. */
static double mk_law_chou_hannaford(double pressure, double length, const double *th)
{
    double c = length / th[MK_CH_B];
    return th[MK_CH_C] * pressure * (3.0 * c * c - 1.0);
}
