/* hunt_quinn.c: the C face of the hunt-quinn law (laws/hunt_quinn.py), for the FMU.
 *
 * F solving P = c0 + c1*tan(c2*(eps/(c4*F + eps_max) + c3)) + c5*F + c6*S, eps = 1 - L/L0, by the
 * Python kernel's bisection, step for step (the same bracket, the same tolerance from theta row
 * MK_HQ_TOL), so the two agree to round-off; held at its eps = 0 value beyond the rest length; 0
 * where the root is negative (slack).
 * Hunt, Graber-Tilton & Quinn (2017), ASME IDETC, paper V05AT08A008.
 * Theta row r at th[r]: rows MK_HQ_* (Law.c_rows). [Pa, m -> N]
 */

/* The model's pressure at force F less the given pressure, into OUT; +-inf outside the tangent's range. */
#define MK_HQ_EXCESS(F, OUT) do { \
        double den_ = th[MK_HQ_C4] * (F) + th[MK_HQ_EMAX], arg_; \
        if (den_ <= 0.0) { (OUT) = INFINITY; break; } \
        arg_ = th[MK_HQ_C2] * (eps / den_ + th[MK_HQ_C3]); \
        if (arg_ >= 1.5707963267948966) { (OUT) = INFINITY; break; } \
        if (arg_ <= -1.5707963267948966) { (OUT) = -INFINITY; break; } \
        (OUT) = th[MK_HQ_C0] + th[MK_HQ_C1] * tan(arg_) + th[MK_HQ_C5] * (F) + th[MK_HQ_C6S] - pressure; \
    } while (0)

static double mk_law_hunt_quinn(double pressure, double length, const double *th)
{
    double eps = 1.0 - length * th[MK_HQ_IL0];
    double lo = -1.0, hi = 1.0, mid, g_lo, g_hi, g, f;
    double tol = th[MK_HQ_TOL];
    int k;
    if (!(eps > 0.0)) eps = 0.0;
    MK_HQ_EXCESS(lo, g);
    for (k = 0; g > 0.0 && k < 200; k++) { lo *= 2.0; MK_HQ_EXCESS(lo, g); }
    MK_HQ_EXCESS(hi, g);
    for (k = 0; g < 0.0 && k < 200; k++) { hi *= 2.0; MK_HQ_EXCESS(hi, g); }
    MK_HQ_EXCESS(lo, g_lo);
    MK_HQ_EXCESS(hi, g_hi);
    if (!(g_lo <= 0.0 && 0.0 <= g_hi)) return NAN;
    for (;;) {
        mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi || hi - lo <= tol * (1.0 + fabs(mid))) break;
        MK_HQ_EXCESS(mid, g);
        if (g < 0.0) lo = mid; else hi = mid;
    }
    f = 0.5 * (lo + hi);
    return f < 0.0 ? 0.0 : f;
}

#undef MK_HQ_EXCESS
