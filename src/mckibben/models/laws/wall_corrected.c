/* The C face of wall_corrected.py (Tsagarakis & Caldwell 2000; Davis et al. 2003): the same
   arithmetic as its kernel, theta row r at th[r]. Pa, m -> N. */
static double mk_law_wall_corrected(double pressure, double length, const double *th)
{
    double c0 = length / th[MK_CH_B];
    double c = c0 < -1.0 ? -1.0 : c0;
    double s, t;
    c = c > 1.0 - 1e-12 ? 1.0 - 1e-12 : c;
    s = sqrt(1.0 - c * c);
    t = th[MK_CH_T];
    return (th[MK_CH_C] * pressure * (3.0 * c0 * c0 - 1.0)
            + MK_PI * pressure * (th[MK_CH_D0] * t * (2.0 * s - 1.0 / s) - t * t));
}
