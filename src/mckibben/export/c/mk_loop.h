/*
 * mk_loop.h: the plant closed by the firmware's own controller core (firmware/core/controller.c),
 * as mckibben.plant.simulate runs a kernel controller: at the start of each control period
 * (MK_TS) the transducer's ADC count is taken (nearest count, halves up, mckibben.hardware),
 * mck_ctrl_step computes the valve commands, and they are held for the period.
 */
#ifndef MK_LOOP_H
#define MK_LOOP_H

#include "mk_plant.h"

#if MK_CONTROLLER
#include "controller.h"

typedef struct {
    mck_ctrl_t ctrl;
    double reference; /* pressure reference [Pa] */
    int faults;       /* the core's fault flags of the last period */
    long tick;        /* the next control tick, t0 + tick*MK_TS */
    double t0;        /* the start of the first control period [s] */
} mk_loop;

/* The core with this FMU's gains, maximum pressure and mode (mk_model.h); the reference kept. */
void mk_loop_init(mk_loop *l);
/* h seconds, the controller stepping at every tick t0 + k*MK_TS on the way: 0 ok, 1 the plant's
   state became non-finite. */
int mk_loop_advance(mk_loop *l, mk_plant *p, double h);
#endif

#endif
