/* Every fmi2 function of the FMI 2.0 standard, for Co-Simulation and Model Exchange.
 *
 * Each function first checks the instance pointer and that it is called in a phase of the
 * call sequence that allows it (a bit mask per function). Any failure logs its reason
 * through the host's logger and returns fmi2Error; the instance then enters the error
 * phase, from which only fmi2Reset, fmi2SetFMUstate, fmi2FreeInstance and the getters
 * lead on (FMI 2.0, section 2.1.3). What a function does with the instance beyond the
 * types of FMI 2.0 is in instance.c, shared with the FMI 3.0 facade.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "framework.h"

#define ANY_PHASE 0x7F
#define ME_SIM (FMU_EVENT_MODE | FMU_CONTINUOUS_MODE)
#define RUNNING (FMU_STEP_COMPLETE | ME_SIM)
#define GETTABLE (FMU_INITIALIZATION | RUNNING | FMU_TERMINATED | FMU_ERROR)

/* The FMI 2.0 instance: the shared part first, then the host's callbacks. */
typedef struct {
    Instance inst;
    fmi2CallbackFunctions cb;
} Fmi2Instance;

#define CALLBACKS(inst) (((const Fmi2Instance *)(inst))->cb)

/* ---------------------------------------------------------------- logging */

static void log_message(const Instance *inst, fmi2Status status, const char *category,
                        const char *format, va_list args) {
    if (!inst || !CALLBACKS(inst).logger) return;
    char message[1024];
    vsnprintf(message, sizeof message, format, args);
    CALLBACKS(inst).logger(CALLBACKS(inst).componentEnvironment, inst->name, status, category, "%s", message);
}

void log_error(const Instance *inst, const char *format, ...) {
    va_list args;
    va_start(args, format);
    log_message(inst, fmi2Error, "logStatusError", format, args);
    va_end(args);
}

void log_event(const Instance *inst, const char *format, ...) {
    if (!inst->logging_on || !inst->log_events) return;
    va_list args;
    va_start(args, format);
    log_message(inst, fmi2OK, "logEvents", format, args);
    va_end(args);
}

/* ---------------------------------------------------------------- guards */

const char *phase_name(FmuPhase phase) {
    switch (phase) {
    case FMU_INSTANTIATED: return "instantiated";
    case FMU_INITIALIZATION: return "initialization mode";
    case FMU_STEP_COMPLETE: return "step complete";
    case FMU_EVENT_MODE: return "event mode";
    case FMU_CONTINUOUS_MODE: return "continuous-time mode";
    case FMU_TERMINATED: return "terminated";
    case FMU_ERROR: return "error";
    }
    return "unknown";
}

static fmi2Status fail(Instance *inst, const char *format, ...) PRINTF_LIKE(2, 3);
static fmi2Status fail(Instance *inst, const char *format, ...) {
    va_list args;
    va_start(args, format);
    log_message(inst, fmi2Error, "logStatusError", format, args);
    va_end(args);
    inst->s.phase = FMU_ERROR;
    return fmi2Error;
}

/* The instance if `c` may call `function` in its current phase, else NULL (logged). */
static Instance *checked(fmi2Component c, const char *function, int allowed, fmi2Type only) {
    Instance *inst = (Instance *)c;
    if (!inst) return NULL;
    if ((int)only >= 0 && inst->co_simulation != (only == fmi2CoSimulation)) {
        fail(inst, "%s is not available in %s", function, inst->co_simulation ? "Co-Simulation" : "Model Exchange");
        return NULL;
    }
    if (!(inst->s.phase & allowed)) {
        const FmuPhase was = inst->s.phase;
        fail(inst, "%s may not be called in phase '%s'", function, phase_name(was));
        return NULL;
    }
    return inst;
}

#define ANY_TYPE ((fmi2Type)-1)
#define CHECK(function, allowed, only)                                                                 \
    Instance *inst = checked(c, function, allowed, only);                                              \
    if (!inst) return fmi2Error

static bool null_arrays(Instance *inst, const char *function, size_t n, const void *vr, const void *value) {
    if (n > 0 && (!vr || !value)) {
        fail(inst, "%s: NULL array for %zu values", function, n);
        return true;
    }
    return false;
}

/* ---------------------------------------------------------------- common functions */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)visible;
    if (!functions) return NULL;
    Fmi2Instance host; /* a stand-in so that errors before allocation still reach the logger */
    memset(&host, 0, sizeof host);
    host.cb = *functions;
    Instance *probe = &host.inst;
    probe->name = (char *)(instanceName ? instanceName : MODEL_IDENTIFIER);
    if (!instanceName || !*instanceName) {
        log_error(probe, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        log_error(probe, "fmi2Instantiate: unknown FMU type %d", (int)fmuType);
        return NULL;
    }
    for (int k = 0; k < N_REAL; k++) probe->start[k] = REAL_INFO[k].start;
    if (!fmuGUID) {
        log_error(probe, "fmi2Instantiate: missing GUID");
        return NULL;
    }
    if (strcmp(fmuGUID, MODEL_GUID) != 0 && !start_values_accept(probe, fmuGUID, fmuResourceLocation)) {
        log_error(probe, "fmi2Instantiate: GUID %s does not match this binary's %s (rebuild the FMU)", fmuGUID,
                  MODEL_GUID);
        return NULL;
    }
    Fmi2Instance *self = functions->allocateMemory ? functions->allocateMemory(1, sizeof(Fmi2Instance))
                                                   : calloc(1, sizeof(Fmi2Instance));
    const size_t name_size = strlen(instanceName) + 1;
    char *name = functions->allocateMemory ? functions->allocateMemory(name_size, 1) : calloc(name_size, 1);
    if (!self || !name) {
        log_error(probe, "fmi2Instantiate: out of memory");
        if (functions->freeMemory) {
            if (self) functions->freeMemory(self);
            if (name) functions->freeMemory(name);
        } else {
            free(self);
            free(name);
        }
        return NULL;
    }
    Instance *inst = &self->inst;
    memcpy(name, instanceName, name_size);
    memcpy(inst->start, probe->start, sizeof inst->start);
    inst->name = name;
    self->cb = *functions;
    inst->co_simulation = fmuType == fmi2CoSimulation;
    inst->logging_on = loggingOn;
    inst->log_events = true;
    instance_reset(inst);
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return;
    if (CALLBACKS(inst).freeMemory) {
        CALLBACKS(inst).freeMemory(inst->name);
        CALLBACKS(inst).freeMemory(inst);
    } else {
        free(inst->name);
        free(inst);
    }
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    CHECK("fmi2SetDebugLogging", ANY_PHASE, ANY_TYPE);
    return instance_set_debug_logging(inst, "fmi2SetDebugLogging", loggingOn, nCategories, categories) ? fmi2OK
                                                                                                      : fmi2Error;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    CHECK("fmi2SetupExperiment", FMU_INSTANTIATED, ANY_TYPE);
    return instance_set_start(inst, "fmi2SetupExperiment", startTime, stopTimeDefined, stopTime) ? fmi2OK : fmi2Error;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    CHECK("fmi2EnterInitializationMode", FMU_INSTANTIATED, ANY_TYPE);
    inst->s.phase = FMU_INITIALIZATION;
    inst->s.outputs = OUTPUTS_STALE;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    CHECK("fmi2ExitInitializationMode", FMU_INITIALIZATION, ANY_TYPE);
    if (!instance_exit_initialization(inst, "fmi2ExitInitializationMode")) return fmi2Error;
    inst->s.phase = inst->co_simulation ? FMU_STEP_COMPLETE : FMU_EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK("fmi2Terminate", RUNNING, ANY_TYPE);
    inst->s.phase = FMU_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    CHECK("fmi2Reset", ANY_PHASE, ANY_TYPE);
    instance_reset(inst);
    return fmi2OK;
}

/* ---------------------------------------------------------------- getters */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    CHECK("fmi2GetReal", GETTABLE, ANY_TYPE);
    if (null_arrays(inst, "fmi2GetReal", nvr, vr, value)) return fmi2Error;
    return instance_get_reals(inst, "fmi2GetReal", vr, nvr, value) ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    CHECK("fmi2GetInteger", GETTABLE, ANY_TYPE);
    if (null_arrays(inst, "fmi2GetInteger", nvr, vr, value)) return fmi2Error;
    return instance_get_integers(inst, "fmi2GetInteger", vr, nvr, value) ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    CHECK("fmi2GetBoolean", GETTABLE, ANY_TYPE);
    if (null_arrays(inst, "fmi2GetBoolean", nvr, vr, value)) return fmi2Error;
    if (!instance_boolean_access(inst, "fmi2GetBoolean", vr, nvr, false)) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) value[k] = inst->s.b[vr[k] - VR_BOOLEAN_BASE];
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    CHECK("fmi2GetString", GETTABLE, ANY_TYPE);
    (void)value;
    if (nvr > 0) return fail(inst, "fmi2GetString: this FMU has no String variables (value reference %u)", vr ? vr[0] : 0);
    return fmi2OK;
}

/* ---------------------------------------------------------------- setters */

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    CHECK("fmi2SetReal", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING, ANY_TYPE);
    if (null_arrays(inst, "fmi2SetReal", nvr, vr, value)) return fmi2Error;
    return instance_set_reals(inst, "fmi2SetReal", vr, nvr, value) ? fmi2OK : fmi2Error;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    CHECK("fmi2SetInteger", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING, ANY_TYPE);
    if (null_arrays(inst, "fmi2SetInteger", nvr, vr, value)) return fmi2Error;
    return instance_set_integers(inst, "fmi2SetInteger", vr, nvr, value) ? fmi2OK : fmi2Error;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    CHECK("fmi2SetBoolean", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING, ANY_TYPE);
    if (null_arrays(inst, "fmi2SetBoolean", nvr, vr, value)) return fmi2Error;
    if (!instance_boolean_access(inst, "fmi2SetBoolean", vr, nvr, true)) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) inst->s.b[vr[k] - VR_BOOLEAN_BASE] = value[k] != fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    CHECK("fmi2SetString", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING, ANY_TYPE);
    (void)value;
    if (nvr > 0) return fail(inst, "fmi2SetString: this FMU has no String variables (value reference %u)", vr ? vr[0] : 0);
    return fmi2OK;
}

/* ---------------------------------------------------------------- FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK("fmi2GetFMUstate", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING | FMU_TERMINATED | FMU_ERROR, ANY_TYPE);
    if (!FMUstate) return fail(inst, "fmi2GetFMUstate: NULL state pointer");
    DynamicState *copy = (DynamicState *)*FMUstate;
    if (!copy) {
        copy = CALLBACKS(inst).allocateMemory ? CALLBACKS(inst).allocateMemory(1, sizeof *copy) : calloc(1, sizeof *copy);
        if (!copy) return fail(inst, "fmi2GetFMUstate: out of memory");
    }
    *copy = inst->s;
    *FMUstate = copy;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    CHECK("fmi2SetFMUstate", ANY_PHASE, ANY_TYPE);
    if (!FMUstate) return fail(inst, "fmi2SetFMUstate: NULL state");
    inst->s = *(const DynamicState *)FMUstate;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK("fmi2FreeFMUstate", ANY_PHASE, ANY_TYPE);
    if (!FMUstate || !*FMUstate) return fmi2OK;
    if (CALLBACKS(inst).freeMemory) CALLBACKS(inst).freeMemory(*FMUstate);
    else free(*FMUstate);
    *FMUstate = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    CHECK("fmi2SerializedFMUstateSize", ANY_PHASE, ANY_TYPE);
    if (!FMUstate || !size) return fail(inst, "fmi2SerializedFMUstateSize: NULL argument");
    *size = instance_serialized_size();
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    CHECK("fmi2SerializeFMUstate", ANY_PHASE, ANY_TYPE);
    if (!FMUstate || !serializedState) return fail(inst, "fmi2SerializeFMUstate: NULL argument");
    return instance_serialize(inst, "fmi2SerializeFMUstate", (const DynamicState *)FMUstate,
                              (unsigned char *)serializedState, size) ? fmi2OK : fmi2Error;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    CHECK("fmi2DeSerializeFMUstate", ANY_PHASE, ANY_TYPE);
    if (!serializedState || !FMUstate) return fail(inst, "fmi2DeSerializeFMUstate: NULL argument");
    DynamicState in;
    if (!instance_deserialize(inst, "fmi2DeSerializeFMUstate", (const unsigned char *)serializedState, size, &in))
        return fmi2Error;
    DynamicState *copy = (DynamicState *)*FMUstate;
    if (!copy) {
        copy = CALLBACKS(inst).allocateMemory ? CALLBACKS(inst).allocateMemory(1, sizeof *copy) : calloc(1, sizeof *copy);
        if (!copy) return fail(inst, "fmi2DeSerializeFMUstate: out of memory");
    }
    *copy = in;
    *FMUstate = copy;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    CHECK("fmi2GetDirectionalDerivative", GETTABLE, ANY_TYPE);
    return fail(inst, "fmi2GetDirectionalDerivative: not provided (providesDirectionalDerivative=false)");
}

/* ---------------------------------------------------------------- Co-Simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    CHECK("fmi2SetRealInputDerivatives", FMU_INITIALIZATION | FMU_STEP_COMPLETE, fmi2CoSimulation);
    if (null_arrays(inst, "fmi2SetRealInputDerivatives", nvr, vr, value)) return fmi2Error;
    if (nvr > 0 && !order) return fail(inst, "fmi2SetRealInputDerivatives: NULL order array");
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] >= N_REAL || REAL_INFO[vr[k]].causality != CAUSALITY_INPUT)
            return fail(inst, "fmi2SetRealInputDerivatives: value reference %u is not a Real input", vr[k]);
        if (order[k] < 1 || order[k] > MAX_INPUT_ORDER)
            return fail(inst, "fmi2SetRealInputDerivatives: order %d of %s outside 1..%d", (int)order[k],
                        REAL_INFO[vr[k]].name, MAX_INPUT_ORDER);
        if (!isfinite(value[k]))
            return fail(inst, "fmi2SetRealInputDerivatives: derivative of %s = %g is not finite", REAL_INFO[vr[k]].name,
                        value[k]);
    }
    if (!inst->s.uder_set || inst->s.uder_time != inst->s.time) {
        for (int j = 0; j < N_INPUTS; j++) { /* derivatives of an earlier point are void */
            memset(inst->s.taylor[INPUT_VR[j]], 0, sizeof inst->s.taylor[0]);
            inst->s.uder_order[INPUT_VR[j]] = 0;
        }
        inst->s.uder_time = inst->s.time;
        inst->s.uder_set = true;
    }
    static const double factorial[MAX_INPUT_ORDER + 1] = {1.0, 1.0, 2.0, 6.0};
    for (size_t k = 0; k < nvr; k++) {
        inst->s.taylor[vr[k]][order[k] - 1] = value[k] / factorial[order[k]];
        int highest = 0;
        for (int j = 1; j <= MAX_INPUT_ORDER; j++)
            if (inst->s.taylor[vr[k]][j - 1] != 0.0) highest = j;
        inst->s.uder_order[vr[k]] = highest;
    }
    return fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    CHECK("fmi2GetRealOutputDerivatives", GETTABLE, fmi2CoSimulation);
    return fail(inst, "fmi2GetRealOutputDerivatives: not provided (maxOutputDerivativeOrder=0)");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK("fmi2DoStep", FMU_STEP_COMPLETE, fmi2CoSimulation);
    return instance_do_step(inst, "fmi2DoStep", currentCommunicationPoint, communicationStepSize) ? fmi2OK
                                                                                                  : fmi2Error;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    CHECK("fmi2CancelStep", FMU_STEP_COMPLETE, fmi2CoSimulation);
    return fail(inst, "fmi2CancelStep: steps are synchronous, there is nothing to cancel");
}

static fmi2Status status_query(fmi2Component c, const char *function, fmi2StatusKind kind, void *value, char type) {
    CHECK(function, RUNNING | FMU_TERMINATED | FMU_ERROR, fmi2CoSimulation);
    if (!value) return fail(inst, "%s: NULL value", function);
    if (kind == fmi2DoStepStatus && type == 's') {
        *(fmi2Status *)value = fmi2OK;
        return fmi2OK;
    }
    if (kind == fmi2LastSuccessfulTime && type == 'r') {
        *(fmi2Real *)value = inst->s.time;
        return fmi2OK;
    }
    if (kind == fmi2Terminated && type == 'b') {
        *(fmi2Boolean *)value = fmi2False;
        return fmi2OK;
    }
    return fail(inst, "%s: status kind %d is not available", function, (int)kind);
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    return status_query(c, "fmi2GetStatus", s, value, 's');
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    return status_query(c, "fmi2GetRealStatus", s, value, 'r');
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    return status_query(c, "fmi2GetIntegerStatus", s, value, 'i');
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    return status_query(c, "fmi2GetBooleanStatus", s, value, 'b');
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    return status_query(c, "fmi2GetStringStatus", s, value, 't');
}

/* ---------------------------------------------------------------- Model Exchange */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    CHECK("fmi2EnterEventMode", ME_SIM, fmi2ModelExchange);
    inst->s.phase = FMU_EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    CHECK("fmi2NewDiscreteStates", FMU_EVENT_MODE, fmi2ModelExchange);
    if (!eventInfo) return fail(inst, "fmi2NewDiscreteStates: NULL eventInfo");
    bool states_changed = false;
    double next_event = INFINITY;
    if (!instance_update_discrete_states(inst, "fmi2NewDiscreteStates", &states_changed, &next_event))
        return fmi2Error;
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = states_changed;
    eventInfo->nextEventTimeDefined = isfinite(next_event) ? fmi2True : fmi2False;
    eventInfo->nextEventTime = isfinite(next_event) ? next_event : 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    CHECK("fmi2EnterContinuousTimeMode", FMU_EVENT_MODE, fmi2ModelExchange);
    inst->s.phase = FMU_CONTINUOUS_MODE;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK("fmi2CompletedIntegratorStep", FMU_CONTINUOUS_MODE, fmi2ModelExchange);
    if (!enterEventMode || !terminateSimulation) return fail(inst, "fmi2CompletedIntegratorStep: NULL argument");
    /* A safety net: an indicator that is negative now means an event was stepped over. */
    *enterEventMode = instance_event_indicator_crossed(inst);
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    CHECK("fmi2SetTime", ME_SIM, fmi2ModelExchange);
    return instance_set_time(inst, "fmi2SetTime", time) ? fmi2OK : fmi2Error;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    CHECK("fmi2SetContinuousStates", FMU_CONTINUOUS_MODE, fmi2ModelExchange);
    return instance_set_states(inst, "fmi2SetContinuousStates", x, nx) ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    CHECK("fmi2GetDerivatives", GETTABLE & ~FMU_INITIALIZATION, fmi2ModelExchange);
    if ((nx > 0 && !derivatives) || nx != N_STATES) return fail(inst, "fmi2GetDerivatives: %zu derivatives asked, %d states", nx, N_STATES);
    model_derivatives(inst, inst->s.time, inst->s.x, derivatives);
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    CHECK("fmi2GetEventIndicators", GETTABLE & ~FMU_INITIALIZATION, fmi2ModelExchange);
    if ((ni > 0 && !eventIndicators) || ni != N_EVENT_INDICATORS)
        return fail(inst, "fmi2GetEventIndicators: %zu indicators asked, %d exist", ni, N_EVENT_INDICATORS);
    model_event_indicators(inst, inst->s.time, inst->s.x, eventIndicators);
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    CHECK("fmi2GetContinuousStates", GETTABLE & ~FMU_INITIALIZATION, fmi2ModelExchange);
    if ((nx > 0 && !x) || nx != N_STATES) return fail(inst, "fmi2GetContinuousStates: %zu states asked, %d exist", nx, N_STATES);
    memcpy(x, inst->s.x, N_STATES * sizeof(double));
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    CHECK("fmi2GetNominalsOfContinuousStates", ANY_PHASE & ~FMU_ERROR, fmi2ModelExchange);
    if ((nx > 0 && !x_nominal) || nx != N_STATES) return fail(inst, "fmi2GetNominalsOfContinuousStates: %zu asked, %d exist", nx, N_STATES);
    for (size_t k = 0; k < nx; k++) x_nominal[k] = 1.0;
    return fmi2OK;
}
