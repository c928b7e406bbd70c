/* Hostile: the smallest FMI 2.0 Co-Simulation FMU that passes `pendfmu check`, made hostile by
   one macro for the tests of its containment (tests/test_check_hostile.py):

     HOSTILE_SEGV  fmi2DoStep writes through a null pointer: SIGSEGV
     HOSTILE_HANG  fmi2DoStep never returns (a busy loop: Ctrl-C cannot interrupt it either)
     HOSTILE_HOG   fmi2DoStep allocates 64 MiB blocks until malloc refuses (at most 16 GiB),
                   then returns fmi2Error saying how much it got

   Only an initialized instance misbehaves: a step before initialization is refused, as the
   call-sequence check expects. The model: y' = k (u - y), y(0) = 0, solved exactly over a
   step with the input held, so any communication step gives the same result. */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define GUID "{6f1d2c3b-0a4e-4b5f-8c7d-hostile00001}"
enum { K, U, Y, N_REALS };
static const double START[N_REALS] = {1.0, 0.0, 0.0};

typedef enum { INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED } Phase;

typedef struct {
    double r[N_REALS];
    double time;
    Phase phase;
    char name[64];
    fmi2CallbackFunctions f;
} Model;

static fmi2Status refuse(Model *m, const char *what) {
    if (m->f.logger)
        m->f.logger(m->f.componentEnvironment, m->name, fmi2Error, "logStatusError", "%s", what);
    return fmi2Error;
}

#ifdef HOSTILE_SEGV
static int *volatile nowhere = NULL;
#endif

static fmi2Status misbehave(Model *m) {
#if defined(HOSTILE_SEGV)
    *nowhere = 1;
#elif defined(HOSTILE_HANG)
    for (volatile unsigned long spin = 0;; spin++) {
    }
#elif defined(HOSTILE_HOG)
    size_t got = 0;
    while (got < ((size_t)16 << 30) && malloc((size_t)64 << 20) != NULL)
        got += (size_t)64 << 20;  /* leaked on purpose */
    char message[96];
    snprintf(message, sizeof message, "out of memory after %zu MiB", got >> 20);
    return refuse(m, message);
#endif
    (void)m;
    return fmi2OK;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID, fmi2String location,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)location; (void)visible; (void)loggingOn;
    if (!functions || !functions->allocateMemory || fmuType != fmi2CoSimulation || !fmuGUID || strcmp(fmuGUID, GUID))
        return NULL;
    Model *m = functions->allocateMemory(1, sizeof(Model));
    if (!m)
        return NULL;
    m->f = *functions;
    snprintf(m->name, sizeof m->name, "%s", instanceName ? instanceName : "");
    memcpy(m->r, START, sizeof START);
    return m;
}

void fmi2FreeInstance(fmi2Component c) {
    Model *m = c;
    if (m)
        m->f.freeMemory(m);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]) {
    (void)c; (void)on; (void)n; (void)categories;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    ((Model *)c)->time = startTime;
    return fmi2OK;
}

static fmi2Status move(Model *m, Phase from, Phase to, const char *refusal) {
    if (m->phase != from)
        return refuse(m, refusal);
    m->phase = to;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return move(c, INSTANTIATED, INITIALIZATION, "fmi2EnterInitializationMode: not after instantiation");
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return move(c, INITIALIZATION, STEPPING, "fmi2ExitInitializationMode: not in initialization mode");
}

fmi2Status fmi2Terminate(fmi2Component c) {
    ((Model *)c)->phase = TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Model *m = c;
    memcpy(m->r, START, sizeof START);
    m->phase = INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Model *m = c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= N_REALS)
            return refuse(m, "fmi2GetReal: unknown value reference");
        value[i] = m->r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Model *m = c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= N_REALS || vr[i] == Y)
            return refuse(m, "fmi2SetReal: not a settable value reference");
        if (vr[i] == K && m->phase == STEPPING)
            return refuse(m, "fmi2SetReal: k is fixed after initialization");
        if (!isfinite(value[i]))
            return refuse(m, "fmi2SetReal: not a finite number");
        m->r[vr[i]] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Model *m = c;
    (void)noSetPrior;
    if (m->phase != STEPPING)
        return refuse(m, "fmi2DoStep: not initialized");
    fmi2Status status = misbehave(m);
    if (status != fmi2OK)
        return status;
    m->r[Y] = m->r[U] + (m->r[Y] - m->r[U]) * exp(-m->r[K] * h);
    m->time = t + h;
    return fmi2OK;
}

/* what Hostile does not do: refused, as FMI allows for a capability not declared */
#define REFUSED(name, ...) fmi2Status name(__VA_ARGS__) { return refuse((Model *)c, #name ": not supported"); }
REFUSED(fmi2GetInteger, fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
REFUSED(fmi2GetBoolean, fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
REFUSED(fmi2GetString, fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
REFUSED(fmi2SetInteger, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[])
REFUSED(fmi2SetBoolean, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[])
REFUSED(fmi2SetString, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[])
REFUSED(fmi2GetFMUstate, fmi2Component c, fmi2FMUstate *s)
REFUSED(fmi2SetFMUstate, fmi2Component c, fmi2FMUstate s)
REFUSED(fmi2FreeFMUstate, fmi2Component c, fmi2FMUstate *s)
REFUSED(fmi2SerializedFMUstateSize, fmi2Component c, fmi2FMUstate s, size_t *n)
REFUSED(fmi2SerializeFMUstate, fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
REFUSED(fmi2DeSerializeFMUstate, fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s)
REFUSED(fmi2GetDirectionalDerivative, fmi2Component c, const fmi2ValueReference u[], size_t nu,
        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real df[])
REFUSED(fmi2SetRealInputDerivatives, fmi2Component c, const fmi2ValueReference vr[], size_t n,
        const fmi2Integer order[], const fmi2Real value[])
REFUSED(fmi2GetRealOutputDerivatives, fmi2Component c, const fmi2ValueReference vr[], size_t n,
        const fmi2Integer order[], fmi2Real value[])
REFUSED(fmi2CancelStep, fmi2Component c)
REFUSED(fmi2GetStatus, fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
REFUSED(fmi2GetRealStatus, fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
REFUSED(fmi2GetIntegerStatus, fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
REFUSED(fmi2GetBooleanStatus, fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
REFUSED(fmi2GetStringStatus, fmi2Component c, const fmi2StatusKind s, fmi2String *value)
