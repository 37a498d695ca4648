/* The C face of braid_map.py (the miniature muscle's braid-angle cubics, eq. 3, and pantograph,
   eq. 2, solved for the load): the same arithmetic as its kernel, theta row r at th[r]. Pa, m -> N. */
static double mk_braid_map_cubic(const double *th, int row, double x)
{
    return ((th[row] * x + th[row + 1]) * x + th[row + 2]) * x + th[row + 3];
}

static double mk_law_braid_map(double pressure, double length, const double *th)
{
    double target = (length - th[MK_BM_K2]) / (th[MK_BM_K1] * th[MK_BM_LS]);
    double x = pressure / MK_MPA;
    int nseg = (int)th[MK_BM_N] - 1;
    double out = NAN;
    double a = mk_braid_map_cubic(th, MK_BM_COEF, x);
    int i;
    for (i = 0; i < MK_MAP_MAX_LOADS - 1; i++) {
        double b = mk_braid_map_cubic(th, MK_BM_COEF + 4 * (i + 1), x);
        double u = (target - a) / (b - a);
        int inside = (u >= 0.0 && u <= 1.0) || (i == 0 && u < 0.0) || (i == nseg - 1 && u > 1.0);
        if (i < nseg && inside && isnan(out) && isfinite(u))
            out = th[MK_BM_LOADS + i] + u * (th[MK_BM_LOADS + i + 1] - th[MK_BM_LOADS + i]);
        a = b;
    }
    return out;
}
