/*
 * fmi3_plant.c: the FMI 3.0 co-simulation interface of the plant (mk_plant.c).
 *
 * Variables (value references, modelDescription.xml): 0 time; 1 pressure [Pa gauge], 2 length [m],
 * 3 force [N] (outputs); 4 inlet, 5 bleed [PWM counts 0..255] (inputs, Int32); 10 supply_pressure
 * [Pa], 11 load_force [N] (parameters); 100 + r the force law's theta row r (parameters).
 * A doStep holds the inputs over the step (zero-order hold) and integrates it in RK4 steps of
 * MK_TS/MK_SUBSTEPS, as mckibben.plant.simulate does over a control period.
 * Built with MK_CONTROLLER (mk_loop.c: the firmware's controller core closes the loop), 4, 5
 * become outputs, 6 reference [Pa] is the input and 7 faults an output.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "mk_loop.h"
#include "mk_plant.h"

enum { MODE_INSTANTIATED, MODE_INIT, MODE_STEP, MODE_TERMINATED };

typedef struct {
    mk_plant pl;
#if MK_CONTROLLER
    mk_loop loop;
#endif
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
    int mode;
    int dirty; /* parameters changed since the state was last set at rest */
    char name[128];
} inst_t;

static void say(inst_t *c, fmi3Status st, const char *msg)
{
    if (c->log)
        c->log(c->env, st, st == fmi3OK ? "logStatusOK" : "logStatusError", msg);
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

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    (void)instance; (void)loggingOn; (void)nCategories; (void)categories;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    inst_t *c;
    (void)resourcePath; (void)visible; (void)loggingOn; (void)eventModeUsed; (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables; (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
    if (instantiationToken && strcmp(instantiationToken, MK_GUID) != 0) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "instantiationToken does not match this FMU's modelDescription.xml");
        return NULL;
    }
    c = (inst_t *)calloc(1, sizeof *c);
    if (!c)
        return NULL;
    mk_defaults(&c->pl);
    c->env = instanceEnvironment;
    c->log = logMessage;
    c->mode = MODE_INSTANTIATED;
    c->dirty = 1;
    snprintf(c->name, sizeof c->name, "%s", instanceName ? instanceName : "");
    return c;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError", "this FMU is co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError", "this FMU is co-simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) { free(instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    inst_t *c = (inst_t *)instance;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    c->mode = MODE_INIT;
    c->dirty = 1;
    settle(c);
    c->pl.time = startTime;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    inst_t *c = (inst_t *)instance;
    char msg[256];
    double t0 = c->pl.time;
    mk_derive(&c->pl);
    if (mk_check(&c->pl, msg, sizeof msg)) {
        say(c, fmi3Error, msg);
        return fmi3Error;
    }
    c->dirty = 1;
    settle(c);
    c->pl.time = t0;
#if MK_CONTROLLER
    c->loop.t0 = t0;
#endif
    c->mode = MODE_STEP;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) { (void)instance; return fmi3Error; }
fmi3Status fmi3Terminate(fmi3Instance instance) { ((inst_t *)instance)->mode = MODE_TERMINATED; return fmi3OK; }

fmi3Status fmi3Reset(fmi3Instance instance)
{
    inst_t *c = (inst_t *)instance;
    mk_defaults(&c->pl);
    c->mode = MODE_INSTANTIATED;
    c->dirty = 1;
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                          size_t nValues)
{
    inst_t *c = (inst_t *)instance;
    double pr, len, f;
    size_t i;
    (void)nValues;
    settle(c);
    mk_outputs(&c->pl, &pr, &len, &f);
    for (i = 0; i < nvr; i++) {
        unsigned v = vr[i];
        if (v == 0) values[i] = c->pl.time;
        else if (v == 1) values[i] = pr;
        else if (v == 2) values[i] = len;
        else if (v == 3) values[i] = f;
        else if (v == 10) values[i] = c->pl.prm[MK_C_supply_pressure];
        else if (v == 11) values[i] = c->pl.prm[MK_C_load_force];
#if MK_CONTROLLER
        else if (v == 6) values[i] = c->loop.reference;
#endif
        else if (v >= 100 && v < 100 + MK_NTH) values[i] = c->pl.th[v - 100];
        else return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Float64 values[], size_t nValues)
{
    inst_t *c = (inst_t *)instance;
    size_t i;
    (void)nValues;
    for (i = 0; i < nvr; i++) {
        unsigned v = vr[i];
#if MK_CONTROLLER
        if (v == 6) {
            c->loop.reference = values[i];
            continue;
        }
#endif
        if (c->mode != MODE_INSTANTIATED && c->mode != MODE_INIT) {
            say(c, fmi3Error, "parameters are fixed: set them before the end of initialization");
            return fmi3Error;
        }
        if (v == 10) c->pl.prm[MK_C_supply_pressure] = values[i];
        else if (v == 11) c->pl.prm[MK_C_load_force] = values[i];
        else if (v >= 100 && v < 100 + MK_NTH) c->pl.th[v - 100] = values[i];
        else return fmi3Error;
        c->dirty = 1;
    }
    return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[],
                        size_t nValues)
{
    inst_t *c = (inst_t *)instance;
    size_t i;
    (void)nValues;
    for (i = 0; i < nvr; i++) {
        if (vr[i] == 4) values[i] = c->pl.inlet;
        else if (vr[i] == 5) values[i] = c->pl.bleed;
#if MK_CONTROLLER
        else if (vr[i] == 7) values[i] = c->loop.faults;
#endif
        else return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 values[],
                        size_t nValues)
{
    inst_t *c = (inst_t *)instance;
    size_t i;
    int in = c->pl.inlet, bl = c->pl.bleed;
    (void)nValues;
#if MK_CONTROLLER
    if (nvr) {
        say(c, fmi3Error, "inlet/bleed are outputs of this FMU: its controller sets them");
        return fmi3Error;
    }
#endif
    for (i = 0; i < nvr; i++) {
        int u = values[i];
        if (u < 0 || u > 255) {
            say(c, fmi3Error, "inlet/bleed: PWM counts must be in 0..255");
            return fmi3Error;
        }
        if (vr[i] == 4) in = u;
        else if (vr[i] == 5) bl = u;
        else return fmi3Error;
    }
    mk_set_commands(&c->pl, in, bl);
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) { (void)instance; return fmi3OK; }

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime)
{
    inst_t *c = (inst_t *)instance;
    int rc;
    (void)noSetFMUStatePriorToCurrentPoint;
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    if (!(communicationStepSize > 0.0)) {
        say(c, fmi3Error, "doStep: the communication step must be > 0");
        return fmi3Error;
    }
    settle(c);
    c->pl.time = currentCommunicationPoint;
#if MK_CONTROLLER
    rc = mk_loop_advance(&c->loop, &c->pl, communicationStepSize);
#else
    rc = mk_advance(&c->pl, communicationStepSize);
#endif
    if (rc) {
        say(c, fmi3Error, "the plant's state became non-finite");
        *lastSuccessfulTime = currentCommunicationPoint;
        return fmi3Error;
    }
    *lastSuccessfulTime = c->pl.time;
    return fmi3OK;
}

/* ---- what this FMU does not do ------------------------------------------------------------- */

#define NO_GETSET(T, N) \
    fmi3Status fmi3Get##N(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, T v[], size_t nv) \
    { (void)c; (void)vr; (void)v; (void)nv; return nvr ? fmi3Error : fmi3OK; } \
    fmi3Status fmi3Set##N(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const T v[], size_t nv) \
    { (void)c; (void)vr; (void)v; (void)nv; return nvr ? fmi3Error : fmi3OK; }

NO_GETSET(fmi3Float32, Float32)
NO_GETSET(fmi3Int8, Int8)
NO_GETSET(fmi3UInt8, UInt8)
NO_GETSET(fmi3Int16, Int16)
NO_GETSET(fmi3UInt16, UInt16)
NO_GETSET(fmi3UInt32, UInt32)
NO_GETSET(fmi3Int64, Int64)
NO_GETSET(fmi3UInt64, UInt64)
NO_GETSET(fmi3Boolean, Boolean)
NO_GETSET(fmi3String, String)

fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, size_t sizes[],
                         fmi3Binary v[], size_t nv)
{ (void)c; (void)vr; (void)sizes; (void)v; (void)nv; return nvr ? fmi3Error : fmi3OK; }
fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const size_t sizes[],
                         const fmi3Binary v[], size_t nv)
{ (void)c; (void)vr; (void)sizes; (void)v; (void)nv; return nvr ? fmi3Error : fmi3OK; }
fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Clock v[])
{ (void)c; (void)vr; (void)v; return nvr ? fmi3Error : fmi3OK; }
fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock v[])
{ (void)c; (void)vr; (void)v; return nvr ? fmi3Error : fmi3OK; }

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference vr, size_t *n)
{ (void)c; (void)vr; (void)n; return fmi3Error; }
fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference dependent, size_t e1[],
                                       fmi3ValueReference independents[], size_t e2[], fmi3DependencyKind kinds[],
                                       size_t n)
{ (void)c; (void)dependent; (void)e1; (void)independents; (void)e2; (void)kinds; (void)n; return fmi3Error; }

fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *s) { (void)c; (void)s; return fmi3Error; }
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState s) { (void)c; (void)s; return fmi3Error; }
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *s) { (void)c; (void)s; return fmi3Error; }
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState s, size_t *n)
{ (void)c; (void)s; (void)n; return fmi3Error; }
fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState s, fmi3Byte b[], size_t n)
{ (void)c; (void)s; (void)b; (void)n; return fmi3Error; }
fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte b[], size_t n, fmi3FMUState *s)
{ (void)c; (void)s; (void)b; (void)n; return fmi3Error; }

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference u[], size_t nu,
                                        const fmi3ValueReference k[], size_t nk, const fmi3Float64 seed[],
                                        size_t ns, fmi3Float64 sens[], size_t nsens)
{ (void)c; (void)u; (void)nu; (void)k; (void)nk; (void)seed; (void)ns; (void)sens; (void)nsens; return fmi3Error; }
fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference u[], size_t nu,
                                    const fmi3ValueReference k[], size_t nk, const fmi3Float64 seed[], size_t ns,
                                    fmi3Float64 sens[], size_t nsens)
{ (void)c; (void)u; (void)nu; (void)k; (void)nk; (void)seed; (void)ns; (void)sens; (void)nsens; return fmi3Error; }

fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) { (void)c; return fmi3Error; }
fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) { (void)c; return fmi3Error; }

fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 iv[],
                                  fmi3IntervalQualifier q[])
{ (void)c; (void)vr; (void)n; (void)iv; (void)q; return fmi3Error; }
fmi3Status fmi3GetIntervalFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt64 cnt[],
                                   fmi3UInt64 res[], fmi3IntervalQualifier q[])
{ (void)c; (void)vr; (void)n; (void)cnt; (void)res; (void)q; return fmi3Error; }
fmi3Status fmi3GetShiftDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 sh[])
{ (void)c; (void)vr; (void)n; (void)sh; return fmi3Error; }
fmi3Status fmi3GetShiftFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt64 cnt[],
                                fmi3UInt64 res[])
{ (void)c; (void)vr; (void)n; (void)cnt; (void)res; return fmi3Error; }
fmi3Status fmi3SetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 iv[])
{ (void)c; (void)vr; (void)n; (void)iv; return fmi3Error; }
fmi3Status fmi3SetIntervalFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
                                   const fmi3UInt64 cnt[], const fmi3UInt64 res[])
{ (void)c; (void)vr; (void)n; (void)cnt; (void)res; return fmi3Error; }
fmi3Status fmi3SetShiftDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 sh[])
{ (void)c; (void)vr; (void)n; (void)sh; return fmi3Error; }
fmi3Status fmi3SetShiftFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 cnt[],
                                const fmi3UInt64 res[])
{ (void)c; (void)vr; (void)n; (void)cnt; (void)res; return fmi3Error; }
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance c) { (void)c; return fmi3Error; }
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *a, fmi3Boolean *b, fmi3Boolean *d, fmi3Boolean *e,
                                    fmi3Boolean *f, fmi3Float64 *g)
{ (void)c; (void)a; (void)b; (void)d; (void)e; (void)f; (void)g; return fmi3Error; }

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { (void)c; return fmi3Error; }
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean a, fmi3Boolean *b, fmi3Boolean *d)
{ (void)c; (void)a; (void)b; (void)d; return fmi3Error; }
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) { (void)c; (void)t; return fmi3Error; }
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n)
{ (void)c; (void)x; (void)n; return fmi3Error; }
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 d[], size_t n)
{ (void)c; (void)d; (void)n; return fmi3Error; }
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 e[], size_t n)
{ (void)c; (void)e; (void)n; return fmi3Error; }
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n)
{ (void)c; (void)x; (void)n; return fmi3Error; }
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n)
{ (void)c; (void)x; (void)n; return fmi3Error; }
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)c; *n = 0; return fmi3OK; }
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { (void)c; *n = 0; return fmi3OK; }

fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 v[], size_t nv)
{ (void)c; (void)vr; (void)nvr; (void)orders; (void)v; (void)nv; return fmi3Error; }
fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference clock, fmi3Float64 t)
{ (void)c; (void)clock; (void)t; return fmi3Error; }
