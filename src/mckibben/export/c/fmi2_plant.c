/*
 * fmi2_plant.c: the FMI 2.0 co-simulation interface of the plant (mk_plant.c).
 *
 * Value references (modelDescription.xml): Real 1 pressure [Pa gauge], 2 length [m], 3 force [N]
 * (outputs), 10 supply_pressure [Pa], 11 load_force [N], 100 + r the force law's theta row r
 * (parameters); Integer 4 inlet, 5 bleed [PWM counts 0..255] (inputs). A doStep holds the inputs
 * over the step and integrates it in RK4 steps of MK_TS/MK_SUBSTEPS, as mckibben.plant.simulate
 * does over a control period.
 * Built with MK_CONTROLLER (mk_loop.c: the firmware's controller core closes the loop), 4, 5
 * become outputs, Real 6 reference [Pa] is the input and Integer 7 faults an output.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "mk_loop.h"
#include "mk_plant.h"

enum { MODE_INSTANTIATED, MODE_INIT, MODE_STEP, MODE_TERMINATED };

typedef struct {
    mk_plant pl;
#if MK_CONTROLLER
    mk_loop loop;
#endif
    fmi2CallbackLogger log;
    fmi2ComponentEnvironment env;
    int mode;
    int dirty;
    char name[128];
} inst_t;

static void say(inst_t *c, fmi2Status st, const char *msg)
{
    if (c->log)
        c->log(c->env, c->name, st, st == fmi2OK ? "logStatusOK" : "logStatusError", "%s", msg);
}

static void settle(inst_t *c)
{
    if (c->dirty) {
        mk_derive(&c->pl);
        mk_initial_state(&c->pl);
#if MK_CONTROLLER
        mk_loop_init(&c->loop);
#endif
        c->dirty = 0;
    }
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n, const fmi2String cats[])
{
    (void)c; (void)loggingOn; (void)n; (void)cats;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    inst_t *c;
    (void)fmuResourceLocation; (void)visible; (void)loggingOn;
    if (fmuType != fmi2CoSimulation || (fmuGUID && strcmp(fmuGUID, MK_GUID) != 0)) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "this FMU is co-simulation only, and the GUID must match its modelDescription.xml");
        return NULL;
    }
    c = (inst_t *)calloc(1, sizeof *c);
    if (!c)
        return NULL;
    mk_defaults(&c->pl);
    c->log = functions ? functions->logger : NULL;
    c->env = functions ? functions->componentEnvironment : NULL;
    c->mode = MODE_INSTANTIATED;
    c->dirty = 1;
    snprintf(c->name, sizeof c->name, "%s", instanceName ? instanceName : "");
    return c;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    inst_t *i = (inst_t *)c;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    settle(i);
    i->pl.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    ((inst_t *)c)->mode = MODE_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    inst_t *i = (inst_t *)c;
    char msg[256];
    double t0 = i->pl.time;
    mk_derive(&i->pl);
    if (mk_check(&i->pl, msg, sizeof msg)) {
        say(i, fmi2Error, msg);
        return fmi2Error;
    }
    i->dirty = 1;
    settle(i);
    i->pl.time = t0;
#if MK_CONTROLLER
    i->loop.t0 = t0;
#endif
    i->mode = MODE_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) { ((inst_t *)c)->mode = MODE_TERMINATED; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c)
{
    inst_t *i = (inst_t *)c;
    mk_defaults(&i->pl);
    i->mode = MODE_INSTANTIATED;
    i->dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    inst_t *i = (inst_t *)c;
    double pr, len, f;
    size_t k;
    settle(i);
    mk_outputs(&i->pl, &pr, &len, &f);
    for (k = 0; k < nvr; k++) {
        unsigned v = vr[k];
        if (v == 1) value[k] = pr;
        else if (v == 2) value[k] = len;
        else if (v == 3) value[k] = f;
        else if (v == 10) value[k] = i->pl.prm[MK_C_supply_pressure];
        else if (v == 11) value[k] = i->pl.prm[MK_C_load_force];
#if MK_CONTROLLER
        else if (v == 6) value[k] = i->loop.reference;
#endif
        else if (v >= 100 && v < 100 + MK_NTH) value[k] = i->pl.th[v - 100];
        else return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    inst_t *i = (inst_t *)c;
    size_t k;
    for (k = 0; k < nvr; k++) {
        unsigned v = vr[k];
#if MK_CONTROLLER
        if (v == 6) {
            i->loop.reference = value[k];
            continue;
        }
#endif
        if (i->mode != MODE_INSTANTIATED && i->mode != MODE_INIT) {
            say(i, fmi2Error, "parameters are fixed: set them before the end of initialization");
            return fmi2Error;
        }
        if (v == 10) i->pl.prm[MK_C_supply_pressure] = value[k];
        else if (v == 11) i->pl.prm[MK_C_load_force] = value[k];
        else if (v >= 100 && v < 100 + MK_NTH) i->pl.th[v - 100] = value[k];
        else return fmi2Error;
        i->dirty = 1;
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    inst_t *i = (inst_t *)c;
    size_t k;
    for (k = 0; k < nvr; k++) {
        if (vr[k] == 4) value[k] = i->pl.inlet;
        else if (vr[k] == 5) value[k] = i->pl.bleed;
#if MK_CONTROLLER
        else if (vr[k] == 7) value[k] = i->loop.faults;
#endif
        else return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    inst_t *i = (inst_t *)c;
    size_t k;
    int in = i->pl.inlet, bl = i->pl.bleed;
#if MK_CONTROLLER
    if (nvr) {
        say(i, fmi2Error, "inlet/bleed are outputs of this FMU: its controller sets them");
        return fmi2Error;
    }
#endif
    for (k = 0; k < nvr; k++) {
        int u = value[k];
        if (u < 0 || u > 255) {
            say(i, fmi2Error, "inlet/bleed: PWM counts must be in 0..255");
            return fmi2Error;
        }
        if (vr[k] == 4) in = u;
        else if (vr[k] == 5) bl = u;
        else return fmi2Error;
    }
    mk_set_commands(&i->pl, in, bl);
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    inst_t *i = (inst_t *)c;
    int rc;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!(communicationStepSize > 0.0)) {
        say(i, fmi2Error, "doStep: the communication step must be > 0");
        return fmi2Error;
    }
    settle(i);
    i->pl.time = currentCommunicationPoint;
#if MK_CONTROLLER
    rc = mk_loop_advance(&i->loop, &i->pl, communicationStepSize);
#else
    rc = mk_advance(&i->pl, communicationStepSize);
#endif
    if (rc) {
        say(i, fmi2Error, "the plant's state became non-finite");
        return fmi2Error;
    }
    return fmi2OK;
}

/* ---- what this FMU does not do ------------------------------------------------------------- */

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{ (void)c; (void)vr; (void)value; return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{ (void)c; (void)vr; (void)value; return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{ (void)c; (void)vr; (void)value; return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{ (void)c; (void)vr; (void)value; return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n)
{ (void)c; (void)s; (void)n; return fmi2Error; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
{ (void)c; (void)s; (void)b; (void)n; return fmi2Error; }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s)
{ (void)c; (void)b; (void)n; (void)s; return fmi2Error; }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference k[], size_t nk, const fmi2Real dk[], fmi2Real du[])
{ (void)c; (void)u; (void)nu; (void)k; (void)nk; (void)dk; (void)du; return fmi2Error; }
fmi2Status fmi2EnterEventMode(fmi2Component c) { (void)c; return fmi2Error; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) { (void)c; (void)e; return fmi2Error; }
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { (void)c; return fmi2Error; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean a, fmi2Boolean *b, fmi2Boolean *d)
{ (void)c; (void)a; (void)b; (void)d; return fmi2Error; }
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { (void)c; (void)t; return fmi2Error; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n)
{ (void)c; (void)x; (void)n; return fmi2Error; }
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real d[], size_t n) { (void)c; (void)d; (void)n; return fmi2Error; }
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real e[], size_t n)
{ (void)c; (void)e; (void)n; return fmi2Error; }
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n)
{ (void)c; (void)x; (void)n; return fmi2Error; }
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n)
{ (void)c; (void)x; (void)n; return fmi2Error; }
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{ (void)c; (void)vr; (void)order; (void)value; return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{ (void)c; (void)vr; (void)order; (void)value; return nvr ? fmi2Error : fmi2OK; }
fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v)
{
    if (s == fmi2LastSuccessfulTime) { *v = ((inst_t *)c)->pl.time; return fmi2OK; }
    return fmi2Discard;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
