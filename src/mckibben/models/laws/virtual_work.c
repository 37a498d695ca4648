/* The C face of virtual_work.py (Chou & Hannaford 1996 effective area; Klute & Hannaford 2000
   elastic energy; Hunt, Graber-Tilton & Quinn 2017 length effect): the same arithmetic as its
   kernel, theta row r at th[r]. Pa, m -> N. */
static double mk_law_virtual_work(double pressure, double length, const double *th)
{
    double l0 = th[MK_VW_L0];
    double eps = (l0 - length) / l0;
    double e0 = th[MK_VW_E0];
    double g0 = th[MK_VW_G0];
    double g, p, f, lam, s;
    if (eps >= 0.0)
        g = g0 * (1.0 - exp(-eps / e0)) + th[MK_VW_G1] * eps;
    else /* stretched beyond the rest length: the tangent at 0, bounded */
        g = (g0 / e0 + th[MK_VW_G1]) * eps;
    p = pressure;
    f = (th[MK_VW_A0] + th[MK_VW_A1] * eps + th[MK_VW_A2] * p) * p - g;
    lam = th[MK_VW_LAM];
    s = lam > 0.0 ? 1.0 + 2.0 * lam / l0 * expm1(-0.5 * l0 / lam) : 1.0;
    return f > 0.0 ? s * f : 0.0;
}
