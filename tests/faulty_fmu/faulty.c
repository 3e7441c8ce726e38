/* A misbehaving FMI 2.0 co-simulation FMU for fault-injection tests: a
 * mass-spring-damper (F_1_z -> u_1_z, v_1_z, a_1_z) that, once the input
 * force reaches fail_force, misbehaves at step fail_step as fail_kind says:
 * 1 fmi2Error, 2 fmi2Fatal (both with a log message), 3 segfault, 4 hang in
 * fmi2DoStep, 5 NaN outputs. Built with -DREFUSE it refuses to instantiate. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { VR_F, VR_U, VR_V, VR_A, VR_M, VR_K, VR_C, VR_KIND, VR_STEP, VR_FORCE, N_VR };

typedef struct {
    fmi2CallbackFunctions cb;
    char *name;
    double r[N_VR];
    long step;
} Inst;

static void defaults(Inst *s) {
    memset(s->r, 0, sizeof s->r);
    s->r[VR_M] = 1.0; s->r[VR_K] = 100.0; s->r[VR_C] = 0.5;
    s->r[VR_STEP] = 10.0; s->r[VR_FORCE] = 1000.0;
    s->step = 0;
}

static void accel(Inst *s) {
    s->r[VR_A] = (s->r[VR_F] - s->r[VR_C] * s->r[VR_V] - s->r[VR_K] * s->r[VR_U]) / s->r[VR_M];
}

static void say(Inst *s, fmi2Status status, const char *msg) {
    s->cb.logger(s->cb.componentEnvironment, s->name, status, "faulty", msg);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String location,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
#ifdef REFUSE
    cb->logger(cb->componentEnvironment, name, fmi2Error, "faulty", "licence server unreachable, refusing to instantiate");
    return NULL;
#else
    Inst *s = calloc(1, sizeof(Inst));
    s->cb = *cb;
    s->name = strdup(name);
    defaults(s);
    return s;
#endif
}

void fmi2FreeInstance(fmi2Component c) {
    if (c) free((void *)((Inst *)c)->name);
    free(c);
}
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tol, fmi2Real t, fmi2Real t0, fmi2Boolean stop, fmi2Real t1) {
    return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { accel(c); return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c) {
    Inst *s = c;
    double keep[N_VR];
    memcpy(keep, s->r, sizeof keep);
    defaults(s);
    for (int i = VR_M; i < N_VR; i++) s->r[i] = keep[i];  /* parameters persist, as set */
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
    accel(s);
    return fmi2OK;
}

static fmi2Status misbehave(Inst *s) {
    char msg[128];
    switch ((int)s->r[VR_KIND]) {
    case 1:
        snprintf(msg, sizeof msg, "stiffness matrix singular at step %ld", s->step);
        say(s, fmi2Error, msg);
        return fmi2Error;
    case 2:
        snprintf(msg, sizeof msg, "solver memory corrupted at step %ld", s->step);
        say(s, fmi2Fatal, msg);
        return fmi2Fatal;
    case 3:
        return *(volatile int *)0 ? fmi2OK : fmi2Error;  /* segmentation fault */
    case 4:
        for (;;) { }  /* hang */
    case 5:
        s->r[VR_U] = s->r[VR_V] = s->r[VR_A] = NAN;
        return fmi2OK;
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean newStep) {
    Inst *s = c;
    if (s->r[VR_KIND] != 0 && s->step >= (long)s->r[VR_STEP] && fabs(s->r[VR_F]) >= s->r[VR_FORCE]) {
        fmi2Status status = misbehave(s);
        s->step++;
        if (status != fmi2OK || s->r[VR_KIND] == 5) return status;
    }
    s->r[VR_V] += h * s->r[VR_A];
    s->r[VR_U] += h * s->r[VR_V];
    accel(s);
    s->step++;
    return fmi2OK;
}

/* unused parts of the interface */
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
