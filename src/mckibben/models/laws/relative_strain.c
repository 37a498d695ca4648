/* The C face of relative_strain.py (Hunt, Graber-Tilton & Quinn 2017: relative strain): the same
   arithmetic as its kernel, theta row r at th[r]. Pa, m -> N. */
static double mk_law_relative_strain(double pressure, double length, const double *th)
{
    double l0 = th[MK_RS_L0];
    double eps = (l0 - length) / (l0 - th[MK_RS_LE]);
    double pp = pressure;
    double f = (th[MK_RS_A1] + th[MK_RS_A2] * pp) * pp - (th[MK_RS_C0] + th[MK_RS_C1] * pp) * eps;
    return f > 0.0 ? f : 0.0;
}
