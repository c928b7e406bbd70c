/* BouncingMass: a mass dropped on a floor, pushed up by an input force, that bounces and
   comes to rest; an FMI 2.0 FMU (Co-Simulation and Model Exchange) written by hand against
   the standard's headers, with nothing from pendfmu (tests/corpus/README.md).

       flying:  h' = v,  v' = F/m - g
       impact (h reaches 0 falling):  v := -e v, bounces += 1; the mass rests when the
           rebound is slower than v_min and F <= m g
       resting: h = v = 0 until F > m g (lift-off)

   Between events the acceleration is constant, so Co-Simulation integrates each step in
   closed form and finds the impacts inside the step (roots of a quadratic): its result does
   not depend on the communication step beyond rounding. Model Exchange gives the host two
   event indicators: the height while flying, and m g - F while resting.

   Broken variants (tests/corpus/build.py compiles them with one of these switches):
     BREAK_EVENTS  impacts decided at communication points only (CS: after the step; ME: no
                   indicator, the impact is asked for in fmi2CompletedIntegratorStep)
     BREAK_STATE   fmi2SetFMUstate restores the Reals but not the discrete variables
     BREAK_RESET   fmi2Reset keeps the parameters set before it
     BREAK_NAN     the predicted impact speed is the square root of a negative number when
                   F > m g, unguarded */

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define GUID "{b0c5e7a4-2d1f-4e8a-9b36-7c41d0a5e912}"

enum { H, V, DER_H, DER_V, F, M, G, E, V_MIN, H0, V_IMPACT, N_REALS };
enum { BOUNCES, RESTING, N_INTEGERS };

typedef enum { STATE, LOCAL, INPUT, PARAMETER, OUTPUT } Kind;

static const struct {
    const char *name;
    Kind kind;
    double start, low, high;  /* a parameter outside [low, high] is refused; low excluded when low_open */
    int low_open;
} REALS[N_REALS] = {
    [H] = {"h", STATE, 0.5, 0, 0, 0},
    [V] = {"v", STATE, 0.0, 0, 0, 0},
    [DER_H] = {"der(h)", LOCAL, 0.0, 0, 0, 0},
    [DER_V] = {"der(v)", LOCAL, 0.0, 0, 0, 0},
    [F] = {"F", INPUT, 0.0, 0, 0, 0},
    [M] = {"m", PARAMETER, 1.0, 0.0, INFINITY, 1},
    [G] = {"g", PARAMETER, 9.81, 0.0, INFINITY, 1},
    [E] = {"e", PARAMETER, 0.7, 0.0, 1.0, 0},
    [V_MIN] = {"v_min", PARAMETER, 0.1, 0.0, INFINITY, 1},
    [H0] = {"h0", PARAMETER, 0.5, 0.0, INFINITY, 0},
    [V_IMPACT] = {"v_impact", OUTPUT, 0.0, 0, 0, 0},
};

typedef enum { INSTANTIATED = 1, INITIALIZATION = 2, STEPPING = 4, EVENT_MODE = 8, CONTINUOUS_MODE = 16,
               TERMINATED = 32, FAILED = 64 } Phase;
#define RUNNING (STEPPING | EVENT_MODE | CONTINUOUS_MODE)
#define ANY_BUT_FAILED (INSTANTIATED | INITIALIZATION | RUNNING | TERMINATED)

/* Everything an FMU state holds. */
typedef struct {
    double time;
    double r[N_REALS];
    int i[N_INTEGERS];
} Data;

typedef struct {
    Data d;
    Phase phase;
    fmi2Type type;
    char name[64];
    fmi2CallbackFunctions cb;
} Instance;

/* -- logging and call order ---------------------------------------------------------- */

/* Logs why a call fails (whatever loggingOn says: an error is always explained). */
static fmi2Status fail(Instance *c, const char *format, ...) __attribute__((format(printf, 2, 3)));

static fmi2Status fail(Instance *c, const char *format, ...) {
    char message[256];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    if (c->cb.logger != NULL)
        c->cb.logger(c->cb.componentEnvironment, c->name, fmi2Error, "logStatusError", "%s", message);
    return fmi2Error;
}

/* Whether `function` may be called now; if not, says so. */
static int allowed(Instance *c, const char *function, unsigned phases) {
    if (c->phase & phases)
        return 1;
    fail(c, "%s is not allowed %s", function,
         c->phase == FAILED ? "after an error (call fmi2Reset)" : "in this state of the instance");
    return 0;
}

/* -- the model ------------------------------------------------------------------------ */

#define R(k) (c->d.r[k])

static double downward(const Instance *c) { return R(G) - R(F) / R(M); }

static void start_values(Instance *c, int keep_parameters) {
    for (int k = 0; k < N_REALS; k++)
        if (!(keep_parameters && REALS[k].kind == PARAMETER))
            R(k) = REALS[k].start;
    memset(c->d.i, 0, sizeof c->d.i);
    c->d.time = 0.0;
}

/* The derivatives and the predicted impact speed: the speed at which the mass would reach
   the floor if the force stayed as it is now (0 if it never would). */
static void update(Instance *c) {
    int resting = c->d.i[RESTING];
    R(DER_H) = resting ? 0.0 : R(V);
    R(DER_V) = resting ? 0.0 : -downward(c);
    double squared = R(V) * R(V) + 2.0 * downward(c) * R(H);
#ifdef BREAK_NAN
    R(V_IMPACT) = sqrt(squared);
#else
    R(V_IMPACT) = squared > 0.0 ? sqrt(squared) : 0.0;
#endif
}

static void settle_or_lift(Instance *c) {
    if (c->d.i[RESTING] && downward(c) < 0.0)
        c->d.i[RESTING] = 0;
    else if (!c->d.i[RESTING] && R(H) <= 0.0 && R(V) == 0.0 && downward(c) >= 0.0)
        c->d.i[RESTING] = 1;
}

static void impact(Instance *c) {
    R(H) = 0.0;
    R(V) = -R(E) * R(V);
    c->d.i[BOUNCES] += 1;
    if (R(V) < R(V_MIN) && downward(c) >= 0.0) {
        R(V) = 0.0;
        c->d.i[RESTING] = 1;
    }
}

/* Time until a flying mass reaches the floor with the force held, INFINITY if never: the
   first positive root of h + v t - a t^2 / 2 = 0, in forms free of cancellation. */
static double time_to_impact(const Instance *c) {
#ifdef BREAK_EVENTS
    (void)c;
    return INFINITY;
#else
    double a = downward(c), h = R(H), v = R(V);
    double discriminant = v * v + 2.0 * a * h;
    if (v < 0.0)
        return discriminant >= 0.0 ? 2.0 * h / (sqrt(discriminant) - v) : INFINITY;
    return a > 0.0 ? (v + sqrt(discriminant)) / a : INFINITY;
#endif
}

static void fly(Instance *c, double t) {
    double a = downward(c);
    R(H) += R(V) * t - 0.5 * a * t * t;
    R(V) -= a * t;
}

static void step(Instance *c, double h) {
    double left = h;
    settle_or_lift(c);
    while (left > 0.0 && !c->d.i[RESTING]) {
        double until = time_to_impact(c);
        if (until > left) {
            fly(c, left);
            break;
        }
        fly(c, until);
        impact(c);
        left -= until;
    }
#ifdef BREAK_EVENTS
    if (!c->d.i[RESTING] && R(H) < 0.0 && R(V) < 0.0)
        impact(c);
#endif
    c->d.time += h;
}

/* -- instance ------------------------------------------------------------------------- */

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)resources, (void)visible, (void)loggingOn;
    Instance probe = {.cb = functions ? *functions : (fmi2CallbackFunctions){0}};
    snprintf(probe.name, sizeof probe.name, "%s", name ? name : "?");
    if (guid == NULL || strcmp(guid, GUID) != 0) {
        fail(&probe, "GUID %s is not this binary's %s: the model description belongs to another FMU",
             guid ? guid : "(null)", GUID);
        return NULL;
    }
    Instance *c = calloc(1, sizeof *c);
    if (c == NULL)
        return NULL;
    *c = probe;
    c->type = type;
    c->phase = INSTANTIATED;
    start_values(c, 0);
    return c;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    if (!allowed(c, "fmi2SetupExperiment", INSTANTIATED))
        return fmi2Error;
    ((Instance *)c)->d.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    if (!allowed(c, "fmi2EnterInitializationMode", INSTANTIATED))
        return fmi2Error;
    ((Instance *)c)->phase = INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component component) {
    Instance *c = component;
    if (!allowed(c, "fmi2ExitInitializationMode", INITIALIZATION))
        return fmi2Error;
    R(H) = R(H0);
    R(V) = 0.0;
    c->d.i[BOUNCES] = 0;
    c->d.i[RESTING] = 0;
    settle_or_lift(c);
    c->phase = c->type == fmi2CoSimulation ? STEPPING : EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    if (!allowed(c, "fmi2Terminate", RUNNING))
        return fmi2Error;
    ((Instance *)c)->phase = TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component component) {
    Instance *c = component;
#ifdef BREAK_RESET
    start_values(c, 1);
#else
    start_values(c, 0);
#endif
    c->phase = INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]) {
    (void)c, (void)on, (void)n, (void)categories;
    return fmi2OK;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

/* -- values --------------------------------------------------------------------------- */

static fmi2Status unknown(Instance *c, const char *function, fmi2ValueReference vr) {
    return fail(c, "%s: unknown value reference %u", function, vr);
}

fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Instance *c = component;
    if (!allowed(c, "fmi2GetReal", ANY_BUT_FAILED))
        return fmi2Error;
    update(c);
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_REALS)
            return unknown(c, "fmi2GetReal", vr[k]);
        value[k] = R(vr[k]);
    }
    return fmi2OK;
}

static fmi2Status set_real(Instance *c, fmi2ValueReference vr, double value) {
    if (vr >= N_REALS)
        return unknown(c, "fmi2SetReal", vr);
    const char *name = REALS[vr].name;
    if (!isfinite(value))
        return fail(c, "%s = %g refused: every value must be finite", name, value);
    if (REALS[vr].kind == PARAMETER) {
        if (!(c->phase & (INSTANTIATED | INITIALIZATION)))
            return fail(c, "%s is a fixed parameter: it cannot be set after initialization", name);
        int below = REALS[vr].low_open ? value <= REALS[vr].low : value < REALS[vr].low;
        if (below || value > REALS[vr].high)
            return fail(c, "%s = %g is out of range [%g, %g]", name, value, REALS[vr].low, REALS[vr].high);
    } else if (REALS[vr].kind != INPUT) {
        return fail(c, "%s is calculated by the FMU: it cannot be set", name);
    }
    R(vr) = value;
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Instance *c = component;
    if (!allowed(c, "fmi2SetReal", INSTANTIATED | INITIALIZATION | RUNNING))
        return fmi2Error;
    for (size_t k = 0; k < n; k++)
        if (set_real(c, vr[k], value[k]) != fmi2OK)
            return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t n, fmi2Integer value[]) {
    Instance *c = component;
    if (!allowed(c, "fmi2GetInteger", ANY_BUT_FAILED))
        return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_INTEGERS)
            return unknown(c, "fmi2GetInteger", vr[k]);
        value[k] = c->d.i[vr[k]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer value[]) {
    (void)value;
    if (n == 0)
        return fmi2OK;
    return vr[0] >= N_INTEGERS ? unknown(c, "fmi2SetInteger", vr[0])
                               : fail(c, "the Integer variables are calculated by the FMU: they cannot be set");
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean value[]) {
    (void)value;
    return n == 0 ? fmi2OK : unknown(c, "fmi2GetBoolean", vr[0]);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean value[]) {
    (void)value;
    return n == 0 ? fmi2OK : unknown(c, "fmi2SetBoolean", vr[0]);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String value[]) {
    (void)value;
    return n == 0 ? fmi2OK : unknown(c, "fmi2GetString", vr[0]);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String value[]) {
    (void)value;
    return n == 0 ? fmi2OK : unknown(c, "fmi2SetString", vr[0]);
}

/* -- FMU state ------------------------------------------------------------------------ */

fmi2Status fmi2GetFMUstate(fmi2Component component, fmi2FMUstate *state) {
    Instance *c = component;
    if (!allowed(c, "fmi2GetFMUstate", ANY_BUT_FAILED))
        return fmi2Error;
    Data *copy = *state != NULL ? *state : malloc(sizeof *copy);
    if (copy == NULL)
        return fail(c, "fmi2GetFMUstate: out of memory");
    *copy = c->d;
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component component, fmi2FMUstate state) {
    Instance *c = component;
    if (!allowed(c, "fmi2SetFMUstate", ANY_BUT_FAILED))
        return fmi2Error;
    if (state == NULL)
        return fail(c, "fmi2SetFMUstate: no state given");
    const Data *saved = state;
#ifdef BREAK_STATE
    c->d.time = saved->time;
    memcpy(c->d.r, saved->r, sizeof c->d.r);
#else
    c->d = *saved;
#endif
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    (void)c;
    free(*state);
    *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    (void)c, (void)state;
    *size = sizeof(Data);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    if (size != sizeof(Data))
        return fail(c, "fmi2SerializeFMUstate: %zu bytes given, a state takes %zu", size, sizeof(Data));
    memcpy(bytes, state, sizeof(Data));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    if (size != sizeof(Data))
        return fail(c, "fmi2DeSerializeFMUstate: %zu bytes given, a state takes %zu", size, sizeof(Data));
    Data *copy = malloc(sizeof *copy);
    if (copy == NULL)
        return fail(c, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(copy, bytes, sizeof *copy);
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz, const fmi2Real dz[],
                                        fmi2Real du[]) {
    (void)u, (void)nu, (void)z, (void)nz, (void)dz, (void)du;
    return fail(c, "fmi2GetDirectionalDerivative is not provided (providesDirectionalDerivative is false)");
}

/* -- Co-Simulation -------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real time, fmi2Real h, fmi2Boolean noSetPrior) {
    Instance *c = component;
    (void)noSetPrior;
    if (!allowed(c, "fmi2DoStep", STEPPING))
        return fmi2Error;
    if (!(h > 0.0) || fabs(time - c->d.time) > 1e-9 * fmax(1.0, fabs(time)))
        return fail(c, "fmi2DoStep(%g, %g): the step must be > 0 and start at the FMU's time %g", time, h, c->d.time);
    step(c, h);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { return fail(c, "fmi2CancelStep: doStep never runs asynchronously"); }

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)n, (void)order, (void)value;
    return fail(c, "fmi2SetRealInputDerivatives: canInterpolateInputs is false");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)n, (void)order, (void)value;
    return fail(c, "fmi2GetRealOutputDerivatives: maxOutputDerivativeOrder is 0");
}

static fmi2Status no_status(fmi2Component c) { return fail(c, "no asynchronous status: doStep never returns fmi2Pending"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s, (void)value;
    return no_status(c);
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    (void)s, (void)value;
    return no_status(c);
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s, (void)value;
    return no_status(c);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s, (void)value;
    return no_status(c);
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s, (void)value;
    return no_status(c);
}

/* -- Model Exchange ------------------------------------------------------------------- */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    if (!allowed(c, "fmi2EnterEventMode", EVENT_MODE | CONTINUOUS_MODE))
        return fmi2Error;
    ((Instance *)c)->phase = EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component component, fmi2EventInfo *info) {
    Instance *c = component;
    if (!allowed(c, "fmi2NewDiscreteStates", EVENT_MODE))
        return fmi2Error;
    int was_resting = c->d.i[RESTING];
    double h = R(H), v = R(V);
    if (!was_resting && h <= 0.0 && v < 0.0)
        impact(c);
    settle_or_lift(c);
    *info = (fmi2EventInfo){.valuesOfContinuousStatesChanged = was_resting != c->d.i[RESTING] || h != R(H) ||
                                                               v != R(V)};
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    if (!allowed(c, "fmi2EnterContinuousTimeMode", EVENT_MODE))
        return fmi2Error;
    ((Instance *)c)->phase = CONTINUOUS_MODE;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component component, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    Instance *c = component;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(c, "fmi2CompletedIntegratorStep", CONTINUOUS_MODE))
        return fmi2Error;
#ifdef BREAK_EVENTS
    *enterEventMode = !c->d.i[RESTING] && R(H) < 0.0 && R(V) < 0.0;
#else
    *enterEventMode = fmi2False;
#endif
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    if (!allowed(c, "fmi2SetTime", EVENT_MODE | CONTINUOUS_MODE))
        return fmi2Error;
    ((Instance *)c)->d.time = time;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component component, const fmi2Real x[], size_t n) {
    Instance *c = component;
    if (!allowed(c, "fmi2SetContinuousStates", CONTINUOUS_MODE))
        return fmi2Error;
    if (n != 2)
        return fail(c, "fmi2SetContinuousStates: %zu states given, the FMU has 2", n);
    if (!isfinite(x[0]) || !isfinite(x[1]))
        return fail(c, "fmi2SetContinuousStates: h = %g, v = %g; states must be finite", x[0], x[1]);
    R(H) = x[0];
    R(V) = x[1];
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component component, fmi2Real x[], size_t n) {
    Instance *c = component;
    if (!allowed(c, "fmi2GetContinuousStates", ANY_BUT_FAILED) || n != 2)
        return n == 2 ? fmi2Error : fail(c, "fmi2GetContinuousStates: %zu states asked, the FMU has 2", n);
    x[0] = R(H);
    x[1] = R(V);
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component component, fmi2Real dx[], size_t n) {
    Instance *c = component;
    if (!allowed(c, "fmi2GetDerivatives", ANY_BUT_FAILED) || n != 2)
        return n == 2 ? fmi2Error : fail(c, "fmi2GetDerivatives: %zu derivatives asked, the FMU has 2", n);
    update(c);
    dx[0] = R(DER_H);
    dx[1] = R(DER_V);
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component component, fmi2Real z[], size_t n) {
    Instance *c = component;
    if (!allowed(c, "fmi2GetEventIndicators", ANY_BUT_FAILED) || n != 2)
        return n == 2 ? fmi2Error : fail(c, "fmi2GetEventIndicators: %zu indicators asked, the FMU has 2", n);
    int resting = c->d.i[RESTING];
#ifdef BREAK_EVENTS
    z[0] = 1.0;
#else
    z[0] = resting ? 1.0 : R(H);
#endif
    z[1] = resting ? R(M) * R(G) - R(F) : 1.0;
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real nominal[], size_t n) {
    (void)c;
    for (size_t k = 0; k < n; k++)
        nominal[k] = 1.0;
    return fmi2OK;
}
