/* A 1-DOF mass-spring-damper FMU "built elsewhere" (FMI 2.0, both
 * co-simulation and model exchange in one binary), as a Modelica tool would
 * export it:  m x'' + d x' + k x = f.
 * Co-simulation integrates with explicit (forward) Euler at the communication
 * step h, OpenModelica's default:  x += h v;  v += h (f - d v - k x) / m,
 * both from the old state, so its poles are 1 + lambda h, |1 + lambda h|^2 =
 * 1 - 2 zeta omega h + (omega h)^2: neutral at omega h = 2 zeta, growing beyond.
 * Output (value reference 1): y = x + y0 (m, a static offset), or with
 * -DVELOCITY the velocity v (m/s). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { VR_F, VR_OUT, VR_M, VR_K, VR_D, VR_Y0, VR_X, VR_DX, VR_V, VR_DV, N_VR };

typedef struct {
    fmi2CallbackFunctions cb;
    double r[N_VR];
    double time;
} Inst;

static void defaults(Inst *s) {
    memset(s->r, 0, sizeof s->r);
    s->r[VR_M] = 1.0; s->r[VR_K] = 1.0e4; s->r[VR_D] = 10.0; s->r[VR_Y0] = 1.0e-3;
    s->time = 0.0;
}

static void update(Inst *s) {  /* derivatives and output from the state and input */
    s->r[VR_DX] = s->r[VR_V];
    s->r[VR_DV] = (s->r[VR_F] - s->r[VR_D] * s->r[VR_V] - s->r[VR_K] * s->r[VR_X]) / s->r[VR_M];
#ifdef VELOCITY
    s->r[VR_OUT] = s->r[VR_V];
#else
    s->r[VR_OUT] = s->r[VR_X] + s->r[VR_Y0];
#endif
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String location,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
    Inst *s = calloc(1, sizeof(Inst));
    s->cb = *cb;
    defaults(s);
    update(s);
    return s;
}
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tol, fmi2Real t, fmi2Real t0, fmi2Boolean stop, fmi2Real t1) {
    ((Inst *)c)->time = t0;
    return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { update(c); return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) {
    Inst *s = c;
    double keep[N_VR];
    memcpy(keep, s->r, sizeof keep);
    defaults(s);
    for (int i = VR_M; i <= VR_Y0; i++) s->r[i] = keep[i];  /* parameters persist */
    update(s);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Inst *s = c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= N_VR) return fmi2Error;
        value[i] = s->r[vr[i]];
    }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Inst *s = c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= N_VR) return fmi2Error;
        s->r[vr[i]] = value[i];
    }
    update(s);
    return fmi2OK;
}

/* ---- co-simulation: explicit Euler at the communication step ---- */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean newStep) {
    Inst *s = c;
    double x = s->r[VR_X], v = s->r[VR_V];
    update(s);
    s->r[VR_X] = x + h * v;
    s->r[VR_V] = v + h * s->r[VR_DV];
    s->time = t + h;
    update(s);
    return fmi2OK;
}

/* ---- model exchange ---- */
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((Inst *)c)->time = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    Inst *s = c;
    s->r[VR_X] = x[0]; s->r[VR_V] = x[1];
    update(s);
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    Inst *s = c;
    x[0] = s->r[VR_X]; x[1] = s->r[VR_V];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) {
    Inst *s = c;
    update(s);
    dx[0] = s->r[VR_DX]; dx[1] = s->r[VR_DV];
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real nominals[], size_t n) {
    for (size_t i = 0; i < n; i++) nominals[i] = 1.0;
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) { return fmi2OK; }
fmi2Status fmi2EnterEventMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    return fmi2OK;
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

/* ---- unused parts of the interface ---- */
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) { return fmi2Error; }
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) { return fmi2Error; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) { return fmi2Error; }
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) { return fmi2Error; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) { return fmi2Error; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) { return fmi2Error; }
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *st) { return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate st) { return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *st) { return fmi2Error; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate st, size_t *n) { return fmi2Error; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate st, fmi2Byte b[], size_t n) { return fmi2Error; }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *st) { return fmi2Error; }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[]) {
    return fmi2Error;
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real v[]) { return fmi2Error; }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real v[]) { return fmi2Error; }
fmi2Status fmi2CancelStep(fmi2Component c) { return fmi2Error; }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status *v) { return fmi2Error; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real *v) { return fmi2Error; }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer *v) { return fmi2Error; }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v) { return fmi2Error; }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *v) { return fmi2Error; }
