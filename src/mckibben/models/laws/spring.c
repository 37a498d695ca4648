/* The C face of spring.py (the spring model F = K(P, Ls)·Ls, eq. 1-2): the same arithmetic as its
   kernel, theta row r at th[r]. Pa, m -> N. */
static double mk_law_spring(double pressure, double length, const double *th)
{
    double pp = pressure;
    double s = length - ((th[MK_SP_H2] * pp + th[MK_SP_H1]) * pp + th[MK_SP_H0]);
    int r = pp <= th[MK_SP_SPLIT] ? MK_SP_LOW : MK_SP_HIGH;
    double k = th[r] * pp + th[r + 1] * pp * s + th[r + 2] * s + th[r + 3];
    return s >= 0.0 ? k * s : 0.0;
}
