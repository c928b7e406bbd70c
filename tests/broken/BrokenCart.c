/* BrokenCart: a small Co-Simulation FMU with stick/slip friction, written for the tests of
   `pendfmu check` (tests/test_check.py). Compiled as is, it passes every check; each BREAK_*
   macro plants one bug that a real exporter has had, for one check to catch:

     BREAK_STATE  fmi2GetFMUstate/fmi2SetFMUstate forget the friction mode (stuck/sliding)
     BREAK_RESET  fmi2Reset keeps the parameters set before it, and 1/m is computed at the
                  first initialization only (a value set after a reset is not used)
     BREAK_STEP   stick/slip decided only at communication points: the friction force takes
                  the sign of the speed at the start of a step and keeps it through the step
     BREAK_NAN    the output `margin` = sqrt(u_rated - u) turns NaN above u_rated while every
                  call returns fmi2OK (the correct one clips at 0)

   The model: m a = k u - c v - F_f with F_f = sign(v) F_c while sliding; stuck (v = 0) while
   |k u| <= F_s. With u held over a step, a sliding phase has a closed form, and the instant
   the cart stops is solved exactly, so the correct FMU gives the same result for every
   communication step. Written against the FMI 2.0 headers only (fmpy's c-code). */

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define GUID "{5d0c1a2e-7b4f-4c1e-9a3d-b20ce4a7f001}"

enum { M, K, C, F_C, F_S, U_RATED, U, X, V, A, MARGIN, N_REALS };
static const double START[N_REALS] = {1.0, 2.0, 1.0, 3.0, 4.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0};
static const char *NAMES[N_REALS] = {"m", "k", "c", "F_c", "F_s", "u_rated", "u", "x", "v", "a", "margin"};
#define N_PARAMETERS 6
#define MODE_VR 0

typedef enum { INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED, FAILED } Phase;

typedef struct {
    double time;
    double r[N_REALS];
    int mode;       /* 0 stuck, +1 sliding forward, -1 sliding backward */
} State;

typedef struct {
    State s;
    double inv_m;   /* 1/m, derived at initialization */
    int derived;    /* BREAK_RESET: derived once only */
    Phase phase;
    char name[64];
    fmi2CallbackFunctions f;
} Cart;

static fmi2Status fail(Cart *c, const char *format, ...) {
    char message[256];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    if (c->f.logger)
        c->f.logger(c->f.componentEnvironment, c->name, fmi2Error, "logStatusError", "%s", message);
    return fmi2Error;
}

static int allowed(Cart *c, const char *function, int phases) {
    if (phases & (1 << c->phase))
        return 1;
    fail(c, "%s: not allowed in this phase (%d)", function, (int)c->phase);
    return 0;
}
#define ANY_BUT_FAILED ((1 << INSTANTIATED) | (1 << INITIALIZATION) | (1 << STEPPING) | (1 << TERMINATED))

static void start_values(Cart *c) {
    memcpy(c->s.r, START, sizeof START);
    c->s.mode = 0;
    c->s.time = 0;
}

static void outputs(Cart *c) {
    double *r = c->s.r;
    int s = c->s.mode;
    r[A] = s == 0 ? 0.0 : (r[K] * r[U] - r[C] * r[V] - s * r[F_C]) * c->inv_m;
#ifdef BREAK_NAN
    r[MARGIN] = sqrt(r[U_RATED] - r[U]);
#else
    r[MARGIN] = sqrt(fmax(0.0, r[U_RATED] - r[U]));
#endif
}

/* Slide with friction direction s for dt: exact solution of m v' = k u - c v - s F_c. */
static void slide(Cart *c, int s, double dt) {
    double *r = c->s.r;
    double tau = r[M] / r[C], v_inf = (r[K] * r[U] - s * r[F_C]) / r[C], e = exp(-dt / tau);
    r[X] += v_inf * dt + (r[V] - v_inf) * tau * (1 - e);
    r[V] = v_inf + (r[V] - v_inf) * e;
}

static void advance(Cart *c, double h) {
    double *r = c->s.r;
    double force = r[K] * r[U];
#ifdef BREAK_STEP
    /* the bug: the friction sign is the speed's sign at the communication point, kept
       through the step; a stop inside the step is never seen */
    if (c->s.mode == 0 && fabs(force) > r[F_S])
        c->s.mode = force > 0 ? 1 : -1;
    if (c->s.mode != 0) {
        if (r[V] != 0)
            c->s.mode = r[V] > 0 ? 1 : -1;
        slide(c, c->s.mode, h);
    }
#else
    double left = h;
    while (left > 0) {
        if (c->s.mode == 0) {
            if (fabs(force) <= r[F_S])
                return;  /* stuck for the rest of the step */
            c->s.mode = force > 0 ? 1 : -1;
        }
        int s = c->s.mode;
        double tau = r[M] / r[C], v_inf = (force - s * r[F_C]) / r[C];
        double stop = INFINITY;
        if (s * v_inf < 0)  /* heading for v = 0 */
            stop = tau * log((r[V] - v_inf) / (0.0 - v_inf));
        if (stop >= left) {
            slide(c, s, left);
            return;
        }
        slide(c, s, stop);
        r[V] = 0.0;
        left -= stop;
        c->s.mode = fabs(force) <= r[F_S] ? 0 : (force > 0 ? 1 : -1);
    }
#endif
}

/* -- common functions */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID, fmi2String location,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)location; (void)visible; (void)loggingOn;
    if (!functions || !functions->allocateMemory || !functions->freeMemory)
        return NULL;
    const char *problem = fmuType != fmi2CoSimulation ? "Co-Simulation only"
                        : (!fmuGUID || strcmp(fmuGUID, GUID) != 0) ? "the GUID does not match this binary's" : NULL;
    if (problem) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError", "%s", problem);
        return NULL;
    }
    Cart *c = functions->allocateMemory(1, sizeof(Cart));
    if (!c)
        return NULL;
    c->f = *functions;
    snprintf(c->name, sizeof c->name, "%s", instanceName ? instanceName : "");
    start_values(c);
    c->phase = INSTANTIATED;
    return c;
}

void fmi2FreeInstance(fmi2Component component) {
    Cart *c = component;
    if (c)
        c->f.freeMemory(c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]) {
    (void)c; (void)on; (void)n; (void)categories;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Cart *c = component;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (!allowed(c, "fmi2SetupExperiment", 1 << INSTANTIATED))
        return fmi2Error;
    c->s.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component component) {
    Cart *c = component;
    if (!allowed(c, "fmi2EnterInitializationMode", 1 << INSTANTIATED))
        return fmi2Error;
    c->phase = INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component component) {
    Cart *c = component;
    if (!allowed(c, "fmi2ExitInitializationMode", 1 << INITIALIZATION))
        return fmi2Error;
#ifdef BREAK_RESET
    if (!c->derived) {
        c->inv_m = 1.0 / c->s.r[M];
        c->derived = 1;
    }
#else
    c->inv_m = 1.0 / c->s.r[M];
#endif
    outputs(c);
    c->phase = STEPPING;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component component) {
    Cart *c = component;
    if (!allowed(c, "fmi2Terminate", 1 << STEPPING))
        return fmi2Error;
    c->phase = TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component component) {
    Cart *c = component;
#ifdef BREAK_RESET
    double kept[N_PARAMETERS];
    memcpy(kept, c->s.r, sizeof kept);
    start_values(c);
    memcpy(c->s.r, kept, sizeof kept);  /* the bug: parameters survive the reset */
#else
    start_values(c);
#endif
    c->phase = INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Cart *c = component;
    if (!allowed(c, "fmi2GetReal", ANY_BUT_FAILED))
        return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= N_REALS)
            return fail(c, "fmi2GetReal: no Real variable has value reference %u", vr[i]);
        value[i] = c->s.r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Cart *c = component;
    if (!allowed(c, "fmi2SetReal", (1 << INSTANTIATED) | (1 << INITIALIZATION) | (1 << STEPPING)))
        return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] > U)
            return fail(c, "fmi2SetReal: no settable Real variable has value reference %u", vr[i]);
        if (vr[i] < N_PARAMETERS && c->phase == STEPPING)
            return fail(c, "fmi2SetReal: %s is a fixed parameter: set it before initialization", NAMES[vr[i]]);
        if (!isfinite(value[i]))
            return fail(c, "fmi2SetReal: %s = %g is not finite", NAMES[vr[i]], value[i]);
        if ((vr[i] == M || vr[i] == C) && !(value[i] > 0))
            return fail(c, "fmi2SetReal: %s = %g must be greater than 0", NAMES[vr[i]], value[i]);
    }
    for (size_t i = 0; i < nvr; i++)
        c->s.r[vr[i]] = value[i];
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    Cart *c = component;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] != MODE_VR)
            return fail(c, "fmi2GetInteger: no Integer variable has value reference %u", vr[i]);
        value[i] = c->s.mode;
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer v[]) {
    (void)vr; (void)v;
    return nvr ? fail(component, "fmi2SetInteger: no settable Integer variable") : fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean v[]) {
    (void)vr; (void)v;
    return nvr ? fail(component, "fmi2GetBoolean: no Boolean variables") : fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean v[]) {
    (void)vr; (void)v;
    return nvr ? fail(component, "fmi2SetBoolean: no Boolean variables") : fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2String v[]) {
    (void)vr; (void)v;
    return nvr ? fail(component, "fmi2GetString: no String variables") : fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, const fmi2String v[]) {
    (void)vr; (void)v;
    return nvr ? fail(component, "fmi2SetString: no String variables") : fmi2OK;
}

/* -- FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component component, fmi2FMUstate *state) {
    Cart *c = component;
    State *copy = *state ? *state : c->f.allocateMemory(1, sizeof(State));
    if (!copy)
        return fail(c, "fmi2GetFMUstate: out of memory");
    *copy = c->s;
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component component, fmi2FMUstate state) {
    Cart *c = component;
    if (!state)
        return fail(c, "fmi2SetFMUstate: no state");
#ifdef BREAK_STATE
    int mode = c->s.mode;
    c->s = *(State *)state;
    c->s.mode = mode;  /* the bug: the friction mode is not part of the saved state */
#else
    c->s = *(State *)state;
#endif
    c->phase = STEPPING;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component component, fmi2FMUstate *state) {
    Cart *c = component;
    if (state && *state) {
        c->f.freeMemory(*state);
        *state = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component component, fmi2FMUstate state, size_t *size) {
    (void)component; (void)state;
    *size = sizeof(State);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component component, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    if (size != sizeof(State))
        return fail(component, "fmi2SerializeFMUstate: %zu bytes, need %zu", size, sizeof(State));
    memcpy(bytes, state, sizeof(State));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component component, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    Cart *c = component;
    if (size != sizeof(State))
        return fail(c, "fmi2DeSerializeFMUstate: %zu bytes, need %zu", size, sizeof(State));
    State *copy = *state ? *state : c->f.allocateMemory(1, sizeof(State));
    if (!copy)
        return fail(c, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(copy, bytes, sizeof(State));
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component component, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference k[], size_t nk, const fmi2Real dk[], fmi2Real du[]) {
    (void)u; (void)nu; (void)k; (void)nk; (void)dk; (void)du;
    return fail(component, "fmi2GetDirectionalDerivative: not provided");
}

/* -- Co-Simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    return fail(component, "fmi2SetRealInputDerivatives: inputs are held (canInterpolateInputs is false)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    return fail(component, "fmi2GetRealOutputDerivatives: not provided");
}

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Cart *c = component;
    (void)noSetPrior;
    if (!allowed(c, "fmi2DoStep", 1 << STEPPING))
        return fmi2Error;
    if (!(h > 0))
        return fail(c, "fmi2DoStep: step size %g is not positive", h);
    if (fabs(t - c->s.time) > 1e-9 * fmax(1.0, fabs(t)))
        return fail(c, "fmi2DoStep: step starts at t = %g but the FMU is at t = %g", t, c->s.time);
    advance(c, h);
    c->s.time = t + h;
    outputs(c);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component component) {
    return fail(component, "fmi2CancelStep: steps are never asynchronous");
}

fmi2Status fmi2GetStatus(fmi2Component component, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value;
    return fail(component, "fmi2GetStatus: steps are never asynchronous");
}

fmi2Status fmi2GetRealStatus(fmi2Component component, const fmi2StatusKind s, fmi2Real *value) {
    Cart *c = component;
    if (s == fmi2LastSuccessfulTime) {
        *value = c->s.time;
        return fmi2OK;
    }
    return fail(c, "fmi2GetRealStatus: only fmi2LastSuccessfulTime");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component component, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value;
    return fail(component, "fmi2GetIntegerStatus: not provided");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component component, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s; (void)value;
    return fail(component, "fmi2GetBooleanStatus: not provided");
}

fmi2Status fmi2GetStringStatus(fmi2Component component, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value;
    return fail(component, "fmi2GetStringStatus: not provided");
}
