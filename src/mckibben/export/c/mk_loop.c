/* mk_loop.c: see mk_loop.h. The sensor model and the reference's rounding are the Python's
   (mckibben.hardware.adc_count, mckibben.control.core.core_step). */
#include <math.h>

#include "mk_loop.h"

#if MK_CONTROLLER
void mk_loop_init(mk_loop *l)
{
    int i;
    mck_ctrl_init(&l->ctrl, (uint16_t)MK_CTRL_TS_US);
    for (i = 0; i < MK_CTRL_N_GAINS; i++)
        mck_ctrl_set_gain(&l->ctrl, (uint8_t)i, (int32_t)MK_CTRL_GAINS[i]);
    mck_ctrl_set_max_pressure(&l->ctrl, (int32_t)MK_CTRL_P_MAX);
    mck_ctrl_set_open_loop(&l->ctrl, (uint8_t)MK_CTRL_OL_INLET, (uint8_t)MK_CTRL_OL_BLEED);
    mck_ctrl_set_mode(&l->ctrl, (uint8_t)MK_CTRL_MODE);
    l->faults = 0;
    l->tick = 0;
    l->t0 = 0.0;
}

static int adc_count(double pressure, double pa_per_count, double adc_zero)
{
    double x = floor(pressure / pa_per_count + adc_zero + 0.5);
    if (x < 0.0)
        return 0;
    if (x > MK_ADC_MAX)
        return MK_ADC_MAX;
    return (int)x;
}

/* The controller runs at the ticks t0 + k*MK_TS (t0: the time at mk_loop_init's state, p->time);
   a step that ends between ticks integrates up to its end and the period goes on in the next one. */
int mk_loop_advance(mk_loop *l, mk_plant *p, double h)
{
    double t_end = p->time + h, tol = 1e-9 * MK_TS;
    while (p->time < t_end - tol) {
        double next = l->t0 + (double)(l->tick) * MK_TS, span;
        if (fabs(p->time - next) <= tol) {
            mck_out_t out;
            double r = l->reference;
            int32_t pref;
            int adc = adc_count(p->s[MK_S_P] - MK_P_ATM, p->prm[MK_C_pa_per_count], p->prm[MK_C_adc_zero]);
            if (!(r > 0.0))
                pref = 0;
            else if (r >= (double)MK_CTRL_P_MAX)
                pref = (int32_t)MK_CTRL_P_MAX;
            else
                pref = (int32_t)floor(r + 0.5);
            mck_ctrl_step(&l->ctrl, (uint16_t)adc, 1u, pref, &out);
            l->faults = out.faults;
            mk_set_commands(p, out.inlet, out.bleed);
            l->tick++;
            p->time = next;
            next = l->t0 + (double)(l->tick) * MK_TS;
        }
        span = (next < t_end ? next : t_end) - p->time;
        if (span > tol) {
            double t = p->time;
            if (mk_advance(p, span))
                return 1;
            p->time = t + span;
        } else {
            p->time = next < t_end ? next : t_end;
        }
    }
    p->time = t_end;
    return 0;
}
#endif
