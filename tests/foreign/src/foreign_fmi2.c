/* The FMI 2.0 functions of the foreign test FMUs (see foreign.h for why this layer exists).

   Compiled with -DFOREIGN_CS for a Co-Simulation FMU or -DFOREIGN_ME for a Model Exchange
   FMU; only that interface's functions are exported, like a tool export of one kind.

   Error policy, as FMI 2.0 describes it: a call that returns fmi2Error logs why (always,
   even with debug logging off, since a host needs the reason) and leaves the instance
   FAILED; from there only getters, fmi2Reset (which brings it back to INSTANTIATED when the
   model supports reset) and fmi2FreeInstance work. A value that is refused is not stored. */

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "foreign.h"

static const char *const PHASE_NAMES[] = {"instantiated", "initialization mode", "stepping", "event mode",
                                          "continuous-time mode", "terminated", "failed"};

fmi2Status fail(Instance *c, const char *format, ...) {
    char message[512];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    if (c->functions.logger)
        c->functions.logger(c->functions.componentEnvironment, c->name, fmi2Error, "logStatusError", "%s", message);
    c->phase = FAILED;
    return fmi2Error;
}

static void debug(Instance *c, const char *function) {
    if (c->debug_logging && c->functions.logger)
        c->functions.logger(c->functions.componentEnvironment, c->name, fmi2OK, "logAll", "%s", function);
}

/* The phases (bit mask) in which a function may be called. */
#define IN(p) (1u << (p))
#define ANY_SETUP (IN(INSTANTIATED) | IN(INITIALIZATION))
#define RUNNING (IN(STEPPING) | IN(EVENT_MODE) | IN(CONTINUOUS_MODE))

static int allowed(Instance *c, const char *function, unsigned phases) {
    if (c == NULL)
        return 0;
    debug(c, function);
    if (phases & IN(c->phase))
        return 1;
    fail(c, "%s is not allowed in %s", function, PHASE_NAMES[c->phase]);
    return 0;
}

static void set_start_values(Instance *c) {
    memset(&c->d, 0, sizeof c->d);
    for (size_t k = 0; k < c->model->n_reals; k++)
        c->d.r[c->model->reals[k].vr] = c->model->reals[k].start;
    for (size_t k = 0; k < c->model->n_integers; k++)
        c->d.i[c->model->integers[k].vr] = c->model->integers[k].start;
}

static const RealVariable *real_variable(const Instance *c, fmi2ValueReference vr) {
    for (size_t k = 0; k < c->model->n_reals; k++)
        if (c->model->reals[k].vr == vr)
            return &c->model->reals[k];
    return NULL;
}

static const IntegerVariable *integer_variable(const Instance *c, fmi2ValueReference vr) {
    for (size_t k = 0; k < c->model->n_integers; k++)
        if (c->model->integers[k].vr == vr)
            return &c->model->integers[k];
    return NULL;
}

/* fmi2OK if `value` may be given to `v` now, else fails the instance with the reason. */
static fmi2Status check_real(Instance *c, const RealVariable *v, double value) {
    if (!isfinite(value))
        return fail(c, "%s = %g: not a finite number", v->name, value);
    if (v->causality == OUTPUT || v->causality == LOCAL)
        return fail(c, "%s is %s and cannot be set", v->name, v->causality == OUTPUT ? "an output" : "a local variable");
    if (v->causality == PARAMETER) {
        if (!(c->phase == INSTANTIATED || c->phase == INITIALIZATION))
            return fail(c, "parameter %s is fixed after initialization (reset the FMU to change it)", v->name);
        int below = v->low_open ? !(value > v->low) : !(value >= v->low);
        if ((below || value > v->high) && isinf(v->high))
            return fail(c, "%s = %g is out of range: %s must be %s %g", v->name, value, v->meaning,
                        v->low_open ? ">" : ">=", v->low);
        if (below || value > v->high)
            return fail(c, "%s = %g is out of range: %s must be in %c%g, %g]", v->name, value, v->meaning,
                        v->low_open ? '(' : '[', v->low, v->high);
    }
    return fmi2OK;
}

/* Common functions */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL || functions->allocateMemory == NULL || functions->freeMemory == NULL)
        return NULL;
    const char *name = instanceName ? instanceName : "";
    const char *problem = NULL;
#ifdef FOREIGN_CS
    if (fmuType != fmi2CoSimulation)
        problem = "this FMU supports Co-Simulation only";
#else
    if (fmuType != fmi2ModelExchange)
        problem = "this FMU supports Model Exchange only";
#endif
    if (fmuGUID == NULL || strcmp(fmuGUID, MODEL.guid) != 0)
        problem = "the GUID does not match this binary's";
    if (problem) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError", "%s", problem);
        return NULL;
    }
    Instance *c = functions->allocateMemory(1, sizeof(Instance));
    char *copy = functions->allocateMemory(strlen(name) + 1, 1);
    if (c == NULL || copy == NULL) {
        if (c) functions->freeMemory(c);
        if (copy) functions->freeMemory(copy);
        return NULL;
    }
    strcpy(copy, name);
    c->name = copy;
    c->model = &MODEL;
    c->functions = *functions;
    c->debug_logging = loggingOn;
    c->phase = INSTANTIATED;
    set_start_values(c);
    return c;
}

void fmi2FreeInstance(fmi2Component component) {
    Instance *c = component;
    if (c == NULL)
        return;
    fmi2CallbackFreeMemory release = c->functions.freeMemory;
    release(c->name);
    release(c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component component, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    Instance *c = component;
    (void)nCategories;
    (void)categories;
    if (c == NULL)
        return fmi2Error;
    c->debug_logging = loggingOn;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Instance *c = component;
    (void)toleranceDefined;
    (void)tolerance;
    if (!allowed(c, "fmi2SetupExperiment", IN(INSTANTIATED)))
        return fmi2Error;
    if (!isfinite(startTime) || (stopTimeDefined && !(stopTime >= startTime)))
        return fail(c, "fmi2SetupExperiment: start time %g, stop time %g", startTime, stopTime);
    c->d.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component component) {
    Instance *c = component;
    if (!allowed(c, "fmi2EnterInitializationMode", IN(INSTANTIATED)))
        return fmi2Error;
    c->phase = INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component component) {
    Instance *c = component;
    if (!allowed(c, "fmi2ExitInitializationMode", IN(INITIALIZATION)))
        return fmi2Error;
    if (c->model->initialize(c) != fmi2OK)
        return fmi2Error;
#ifdef FOREIGN_CS
    c->phase = STEPPING;
#else
    c->phase = EVENT_MODE;
#endif
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component component) {
    Instance *c = component;
    if (!allowed(c, "fmi2Terminate", RUNNING))
        return fmi2Error;
    c->phase = TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component component) {
    Instance *c = component;
    if (c == NULL)
        return fmi2Error;
    debug(c, "fmi2Reset");
    if (!c->model->can_reset)
        return fail(c, "fmi2Reset is not supported by %s: free this instance and instantiate a new one", c->model->name);
    c->phase = INSTANTIATED;
#ifdef MUTANT_RESET_KEEPS_PARAMETERS
    /* A planted bug (tests/foreign/mutants.py): the parameters set before the reset are kept. */
    Data before = c->d;
    set_start_values(c);
    for (size_t k = 0; k < c->model->n_reals; k++)
        if (c->model->reals[k].causality == PARAMETER)
            c->d.r[c->model->reals[k].vr] = before.r[c->model->reals[k].vr];
#else
    set_start_values(c);
#endif
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Instance *c = component;
    if (c == NULL)
        return fmi2Error;
    if (c->phase == INITIALIZATION && c->model->initialize(c) != fmi2OK)
        return fmi2Error;
    if (c->model->update)
        c->model->update(c);
    for (size_t k = 0; k < nvr; k++) {
        if (real_variable(c, vr[k]) == NULL)
            return fail(c, "fmi2GetReal: unknown value reference %u", vr[k]);
        value[k] = c->d.r[vr[k]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Instance *c = component;
    if (!allowed(c, "fmi2SetReal", ANY_SETUP | RUNNING))
        return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        const RealVariable *v = real_variable(c, vr[k]);
        if (v == NULL)
            return fail(c, "fmi2SetReal: unknown value reference %u", vr[k]);
        if (check_real(c, v, value[k]) != fmi2OK)
            return fmi2Error;
        c->d.r[vr[k]] = value[k];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    Instance *c = component;
    if (c == NULL)
        return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        if (integer_variable(c, vr[k]) == NULL)
            return fail(c, "fmi2GetInteger: unknown value reference %u", vr[k]);
        value[k] = c->d.i[vr[k]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    Instance *c = component;
    (void)value;
    if (c == NULL)
        return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        const IntegerVariable *v = integer_variable(c, vr[k]);
        return v ? fail(c, "%s is a local variable and cannot be set", v->name)
                 : fail(c, "fmi2SetInteger: unknown value reference %u", vr[k]);
    }
    return fmi2OK;
}

/* No Boolean or String variables: any value reference is unknown. */
static fmi2Status no_variables(Instance *c, const char *function, size_t nvr, const fmi2ValueReference vr[]) {
    if (c == NULL)
        return fmi2Error;
    return nvr == 0 ? fmi2OK : fail(c, "%s: unknown value reference %u", function, vr[0]);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    (void)value;
    return no_variables(c, "fmi2GetBoolean", nvr, vr);
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    (void)value;
    return no_variables(c, "fmi2SetBoolean", nvr, vr);
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)value;
    return no_variables(c, "fmi2GetString", nvr, vr);
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)value;
    return no_variables(c, "fmi2SetString", nvr, vr);
}

/* FMU state: a copy of Data and the phase, serialized behind a tag and its size so that
   bytes that are not such a state are refused. */

typedef struct {
    Data d;
    Phase phase;
} State;

#define STATE_TAG 0x46475331u /* "FGS1" */

static int states_supported(Instance *c, const char *function) {
    if (c == NULL)
        return 0;
    debug(c, function);
    if (c->model->can_get_set_state)
        return 1;
    fail(c, "%s: %s does not support FMU states (canGetAndSetFMUstate is false)", function, c->model->name);
    return 0;
}

fmi2Status fmi2GetFMUstate(fmi2Component component, fmi2FMUstate *FMUstate) {
    Instance *c = component;
    if (!states_supported(c, "fmi2GetFMUstate"))
        return fmi2Error;
    State *s = *FMUstate ? *FMUstate : c->functions.allocateMemory(1, sizeof(State));
    if (s == NULL)
        return fail(c, "fmi2GetFMUstate: out of memory");
    s->d = c->d;
    s->phase = c->phase;
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component component, fmi2FMUstate FMUstate) {
    Instance *c = component;
    if (!states_supported(c, "fmi2SetFMUstate"))
        return fmi2Error;
    if (FMUstate == NULL)
        return fail(c, "fmi2SetFMUstate: no state given");
    const State *s = FMUstate;
#ifdef MUTANT_FORGET_MODE
    /* A planted bug (tests/foreign/mutants.py): the Integer variables (the mode) are not restored. */
    int kept[MAX_INTEGERS];
    memcpy(kept, c->d.i, sizeof kept);
    c->d = s->d;
    memcpy(c->d.i, kept, sizeof kept);
#else
    c->d = s->d;
#endif
    c->phase = s->phase;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component component, fmi2FMUstate *FMUstate) {
    Instance *c = component;
    if (!states_supported(c, "fmi2FreeFMUstate"))
        return fmi2Error;
    if (FMUstate && *FMUstate) {
        c->functions.freeMemory(*FMUstate);
        *FMUstate = NULL;
    }
    return fmi2OK;
}

#define SERIAL_SIZE (2 * sizeof(unsigned) + sizeof(State))

fmi2Status fmi2SerializedFMUstateSize(fmi2Component component, fmi2FMUstate FMUstate, size_t *size) {
    Instance *c = component;
    (void)FMUstate;
    if (!states_supported(c, "fmi2SerializedFMUstateSize"))
        return fmi2Error;
    *size = SERIAL_SIZE;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component component, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    Instance *c = component;
    if (!states_supported(c, "fmi2SerializeFMUstate"))
        return fmi2Error;
    if (FMUstate == NULL || size < SERIAL_SIZE)
        return fail(c, "fmi2SerializeFMUstate: no state, or a buffer of %zu bytes (needs %zu)", size, SERIAL_SIZE);
    unsigned header[2] = {STATE_TAG, (unsigned)sizeof(State)};
    memcpy(serializedState, header, sizeof header);
    memcpy(serializedState + sizeof header, FMUstate, sizeof(State));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component component, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    Instance *c = component;
    if (!states_supported(c, "fmi2DeSerializeFMUstate"))
        return fmi2Error;
    unsigned header[2];
    if (size != SERIAL_SIZE)
        return fail(c, "fmi2DeSerializeFMUstate: %zu bytes is not a state of %s", size, MODEL.name);
    memcpy(header, serializedState, sizeof header);
    if (header[0] != STATE_TAG || header[1] != (unsigned)sizeof(State))
        return fail(c, "fmi2DeSerializeFMUstate: not a state of %s", MODEL.name);
    State *s = *FMUstate ? *FMUstate : c->functions.allocateMemory(1, sizeof(State));
    if (s == NULL)
        return fail(c, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(s, serializedState + sizeof header, sizeof(State));
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component component, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    Instance *c = component;
    return c ? fail(c, "fmi2GetDirectionalDerivative is not provided") : fmi2Error;
}

#ifdef FOREIGN_CS

fmi2Status fmi2SetRealInputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    Instance *c = component;
    return c ? fail(c, "fmi2SetRealInputDerivatives: inputs are held (canInterpolateInputs is false)") : fmi2Error;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    Instance *c = component;
    return c ? fail(c, "fmi2GetRealOutputDerivatives is not provided (maxOutputDerivativeOrder 0)") : fmi2Error;
}

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *c = component;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(c, "fmi2DoStep", IN(STEPPING)))
        return fmi2Error;
    double t = currentCommunicationPoint, h = communicationStepSize;
    if (!(isfinite(h) && h > 0))
        return fail(c, "fmi2DoStep: step size %g must be positive and finite", h);
    /* The host's clock and ours may differ by rounding (k*dt against a sum of dt). */
    if (!isfinite(t) || fabs(t - c->d.time) > 1e-9 * (1.0 + fabs(t)))
        return fail(c, "fmi2DoStep: communication point %.17g, but the FMU is at %.17g", t, c->d.time);
    if (c->model->do_step(c, h) != fmi2OK)
        return fmi2Error;
    c->d.time = t + h;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component component) {
    Instance *c = component;
    return c ? fail(c, "fmi2CancelStep: steps are never asynchronous") : fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component component, const fmi2StatusKind s, fmi2Status *value) {
    (void)s, (void)value;
    Instance *c = component;
    return c ? fail(c, "fmi2GetStatus: steps are never asynchronous") : fmi2Error;
}

fmi2Status fmi2GetRealStatus(fmi2Component component, const fmi2StatusKind s, fmi2Real *value) {
    Instance *c = component;
    if (c == NULL)
        return fmi2Error;
    if (s != fmi2LastSuccessfulTime)
        return fail(c, "fmi2GetRealStatus: only fmi2LastSuccessfulTime is provided");
    *value = c->d.time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component component, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s, (void)value;
    Instance *c = component;
    return c ? fail(c, "fmi2GetIntegerStatus: no integer status") : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component component, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s, (void)value;
    Instance *c = component;
    return c ? fail(c, "fmi2GetBooleanStatus: no boolean status") : fmi2Error;
}

fmi2Status fmi2GetStringStatus(fmi2Component component, const fmi2StatusKind s, fmi2String *value) {
    (void)s, (void)value;
    Instance *c = component;
    return c ? fail(c, "fmi2GetStringStatus: no string status") : fmi2Error;
}

#endif /* FOREIGN_CS */

#ifdef FOREIGN_ME

fmi2Status fmi2EnterEventMode(fmi2Component component) {
    Instance *c = component;
    if (!allowed(c, "fmi2EnterEventMode", IN(EVENT_MODE) | IN(CONTINUOUS_MODE)))
        return fmi2Error;
    c->phase = EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component component, fmi2EventInfo *info) {
    Instance *c = component;
    if (!allowed(c, "fmi2NewDiscreteStates", IN(EVENT_MODE)))
        return fmi2Error;
    /* No discrete states, no time events: every event iteration ends at once. */
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component component) {
    Instance *c = component;
    if (!allowed(c, "fmi2EnterContinuousTimeMode", IN(EVENT_MODE)))
        return fmi2Error;
    c->phase = CONTINUOUS_MODE;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component component, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    Instance *c = component;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(c, "fmi2CompletedIntegratorStep", IN(CONTINUOUS_MODE)))
        return fmi2Error;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component component, fmi2Real time) {
    Instance *c = component;
    if (!allowed(c, "fmi2SetTime", ANY_SETUP | IN(EVENT_MODE) | IN(CONTINUOUS_MODE)))
        return fmi2Error;
    if (!isfinite(time))
        return fail(c, "fmi2SetTime: time %g is not finite", time);
    c->d.time = time;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component component, const fmi2Real x[], size_t nx) {
    Instance *c = component;
    if (!allowed(c, "fmi2SetContinuousStates", IN(EVENT_MODE) | IN(CONTINUOUS_MODE)))
        return fmi2Error;
    if (nx != c->model->n_states)
        return fail(c, "fmi2SetContinuousStates: %zu states given, the model has %zu", nx, c->model->n_states);
    for (size_t k = 0; k < nx; k++)
        if (!isfinite(x[k]))
            return fail(c, "fmi2SetContinuousStates: state %zu = %g is not finite", k, x[k]);
    for (size_t k = 0; k < nx; k++)
        c->d.r[c->model->state_vrs[k]] = x[k];
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component component, fmi2Real x[], size_t nx) {
    Instance *c = component;
    if (c == NULL)
        return fmi2Error;
    if (nx != c->model->n_states)
        return fail(c, "fmi2GetContinuousStates: %zu states asked, the model has %zu", nx, c->model->n_states);
    for (size_t k = 0; k < nx; k++)
        x[k] = c->d.r[c->model->state_vrs[k]];
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component component, fmi2Real derivatives[], size_t nx) {
    Instance *c = component;
    if (!allowed(c, "fmi2GetDerivatives", IN(INITIALIZATION) | IN(EVENT_MODE) | IN(CONTINUOUS_MODE)))
        return fmi2Error;
    if (nx != c->model->n_states)
        return fail(c, "fmi2GetDerivatives: %zu derivatives asked, the model has %zu", nx, c->model->n_states);
    c->model->update(c);
    for (size_t k = 0; k < nx; k++)
        derivatives[k] = c->d.r[c->model->derivative_vrs[k]];
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component component, fmi2Real eventIndicators[], size_t ni) {
    Instance *c = component;
    (void)eventIndicators;
    if (c == NULL)
        return fmi2Error;
    return ni == 0 ? fmi2OK : fail(c, "fmi2GetEventIndicators: the model has no event indicators, %zu asked", ni);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component component, fmi2Real x_nominal[], size_t nx) {
    Instance *c = component;
    if (c == NULL)
        return fmi2Error;
    if (nx != c->model->n_states)
        return fail(c, "fmi2GetNominalsOfContinuousStates: %zu asked, the model has %zu", nx, c->model->n_states);
    for (size_t k = 0; k < nx; k++)
        x_nominal[k] = 1.0;
    return fmi2OK;
}

#endif /* FOREIGN_ME */
