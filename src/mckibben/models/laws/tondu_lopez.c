/* The C face of tondu_lopez.py (Tondu & Lopez 2000, eq. 4, with a pressure threshold): the same
   arithmetic as its kernel, theta row r at th[r]. Pa, m -> N. */
static double mk_law_tondu_lopez(double pressure, double length, const double *th)
{
    double r0 = th[MK_TL_R0];
    double dp = pressure - th[MK_TL_PTH];
    double q;
    dp = dp > 0.0 ? dp : 0.0;
    q = 1.0 - th[MK_TL_K] * (1.0 - length * th[MK_TL_IL0]);
    return MK_PI * r0 * r0 * dp * (th[MK_TL_A] * q * q - th[MK_TL_B]);
}
