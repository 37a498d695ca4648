/*
 * mk_plant.h: the McKibben rig's plant in C99, one instance (valves -> chamber -> muscle -> load).
 *
 * A port of the Numba plant, mckibben.plant.physics and mckibben.plant.packing.derive_columns, which is the
 * source of truth: the same equations, the same classical RK4 with the same substep, the same
 * force law by index. The layout (parameter columns, law indices, theta rows) and this FMU's
 * values come from the generated mk_model.h, written from the Python objects at export.
 * tests/test_export_fmu.py holds this file equal to mckibben.plant.simulate().
 */
#ifndef MK_PLANT_H
#define MK_PLANT_H

#include "mk_model.h"

#define MK_NS 8
enum { MK_S_P, MK_S_T, MK_S_XIN, MK_S_XBL, MK_S_LEN, MK_S_VEL, MK_S_FRIC, MK_S_PLAY };

typedef struct {
    double prm[MK_NP];   /* packed parameters: the fields, then the derived columns (mk_derive) */
    double th[MK_NTH];   /* the force law's parameters (theta) */
    int law;             /* the law's index in mckibben.models.laws.LAW_NAMES */
    double s[MK_NS];     /* state: p [Pa abs], T [K], x_in, x_bl [-], l [m], v [m/s], z [N], play output [Pa gauge] */
    double x_in_target;  /* valve openings commanded (held over a step) [-] */
    double x_bl_target;
    int inlet, bleed;    /* PWM commands [counts] */
    double time;         /* [s] */
} mk_plant;

/* The values of this FMU (mk_model.h) into p; then mk_derive. */
void mk_defaults(mk_plant *p);
/* The derived columns from the fields (mckibben.plant.packing.derive_columns). */
void mk_derive(mk_plant *p);
/* 0 when the tunable parameters are runnable, else 1 with a one-line message in msg. */
int mk_check(const mk_plant *p, char *msg, int size);
/* The state at rest: gauge 0, the gas at the wall temperature, valves shut, the static length, the play at 0. */
void mk_initial_state(mk_plant *p);
/* Valve targets of the current commands (call before mk_advance). */
void mk_set_commands(mk_plant *p, int inlet, int bleed);
/* Advance h seconds in RK4 steps of MK_TS/MK_SUBSTEPS (h/n when h is no multiple of it);
   0 ok, 1 the state became non-finite. */
int mk_advance(mk_plant *p, double h);
/* Gauge pressure [Pa], length [m] and pulling force [N] now. */
void mk_outputs(const mk_plant *p, double *pressure, double *length, double *force);
/* The registered law at a gauge pressure [Pa] and length [m] (its raw value) [N]. */
double mk_law(int law, double pressure, double length, const double *th);
/* Valve opening commanded by a PWM count through the driver and dead band [-]. */
double mk_valve_target(double pwm, double drv, double db);

#endif
