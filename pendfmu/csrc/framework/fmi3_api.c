/* Every fmi3 function of the FMI 3.0 standard, for Co-Simulation (with or without event
 * mode) and Model Exchange; no Scheduled Execution, clocks or structural parameters.
 *
 * The FMI 3.0 facade over the same Instance, model and solver as fmi2_api.c: each function
 * checks the instance pointer and the phase it is called in, converts FMI 3.0's types, and
 * leaves the work to instance.c, so an FMI 3.0 FMU computes exactly what the FMI 2.0 FMU of
 * the component computes. A failure logs its reason through the host's logMessage callback
 * and returns fmi3Error; the instance is then in the error phase, from which fmi3Reset,
 * fmi3SetFMUState, fmi3FreeInstance and the getters lead on.
 *
 * What FMI 3.0 adds for our components:
 *   - Co-Simulation with event mode: a step that ends on a time event (a controller's
 *     sample) returns eventHandlingNeeded; the importer enters Event Mode, sets the inputs
 *     of that instant and calls fmi3UpdateDiscreteStates, which takes the event. Without
 *     event mode the next step takes it, as in FMI 2.0.
 *   - Event indicators are variables: event_indicator_<k> at value references after the
 *     table's (pendfmu/fmubuild/description3.py), computed when read.
 * Inputs are held over a Co-Simulation step: FMI 3.0 has no call for input derivatives.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "framework.h"

#define ANY_PHASE 0x7F
#define ME_SIM (FMU_EVENT_MODE | FMU_CONTINUOUS_MODE)
#define RUNNING (FMU_STEP_COMPLETE | ME_SIM)
#define GETTABLE (FMU_INITIALIZATION | RUNNING | FMU_TERMINATED | FMU_ERROR)
#define SETTABLE (FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING)
/* The value reference of the first event-indicator variable: after the table's variables;
 * then the independent variable, time (pendfmu/fmubuild/description3.py). */
#define VR_EVENT_INDICATOR_BASE (VR_BOOLEAN_BASE + N_BOOLEAN)
#define VR_TIME (VR_EVENT_INDICATOR_BASE + N_EVENT_INDICATORS)

/* The FMI 3.0 instance: the shared part first, then the host's callback. */
typedef struct {
    Instance inst;
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log_message;
} Fmi3Instance;

#define HOST(inst) ((const Fmi3Instance *)(inst))

/* ---------------------------------------------------------------- logging */

static void log_message(const Instance *inst, fmi3Status status, const char *category, const char *format,
                        va_list args) {
    if (!inst || !HOST(inst)->log_message) return;
    char message[1024];
    vsnprintf(message, sizeof message, format, args);
    HOST(inst)->log_message(HOST(inst)->environment, status, category, message);
}

void log_error(const Instance *inst, const char *format, ...) {
    va_list args;
    va_start(args, format);
    log_message(inst, fmi3Error, "logStatusError", format, args);
    va_end(args);
}

void log_event(const Instance *inst, const char *format, ...) {
    if (!inst->logging_on || !inst->log_events) return;
    va_list args;
    va_start(args, format);
    log_message(inst, fmi3OK, "logEvents", format, args);
    va_end(args);
}

/* ---------------------------------------------------------------- guards */

const char *phase_name(FmuPhase phase) {
    switch (phase) {
    case FMU_INSTANTIATED: return "Instantiated";
    case FMU_INITIALIZATION: return "Initialization Mode";
    case FMU_STEP_COMPLETE: return "Step Mode";
    case FMU_EVENT_MODE: return "Event Mode";
    case FMU_CONTINUOUS_MODE: return "Continuous-Time Mode";
    case FMU_TERMINATED: return "Terminated";
    case FMU_ERROR: return "Error";
    }
    return "unknown";
}

static fmi3Status fail(Instance *inst, const char *format, ...) PRINTF_LIKE(2, 3);
static fmi3Status fail(Instance *inst, const char *format, ...) {
    char message[1024];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    instance_fail(inst, "%s", message);
    return fmi3Error;
}

typedef enum { ANY_INTERFACE, ONLY_MODEL_EXCHANGE, ONLY_CO_SIMULATION } InterfaceRequirement;

/* The instance if `instance` may call `function` in its current phase, else NULL (logged). */
static Instance *checked(fmi3Instance instance, const char *function, int allowed, InterfaceRequirement only) {
    Instance *inst = (Instance *)instance;
    if (!inst) return NULL;
    if ((only == ONLY_MODEL_EXCHANGE && inst->co_simulation) || (only == ONLY_CO_SIMULATION && !inst->co_simulation)) {
        fail(inst, "%s is not available in %s", function, inst->co_simulation ? "Co-Simulation" : "Model Exchange");
        return NULL;
    }
    if (!(inst->s.phase & allowed)) {
        fail(inst, "%s may not be called in %s", function, phase_name(inst->s.phase));
        return NULL;
    }
    return inst;
}

#define CHECK(function, allowed, only)                                                                  \
    Instance *inst = checked(instance, function, allowed, only);                                        \
    if (!inst) return fmi3Error

#define STATUS(ok) ((ok) ? fmi3OK : fmi3Error)

static bool null_arrays(Instance *inst, const char *function, size_t n, const void *vr, const void *value) {
    if (n > 0 && (!vr || !value)) {
        fail(inst, "%s: NULL array for %zu values", function, n);
        return true;
    }
    return false;
}

/* The counts of a getter or setter: one value per value reference (no arrays here). */
static bool bad_counts(Instance *inst, const char *function, size_t nvr, const void *vr, size_t n, const void *value) {
    if (null_arrays(inst, function, nvr, vr, value)) return true;
    if (n != nvr) {
        fail(inst, "%s: %zu values for %zu value references (this FMU has no array variables)", function, n, nvr);
        return true;
    }
    return false;
}

/* ---------------------------------------------------------------- life cycle */

const char *fmi3GetVersion(void) { return fmi3Version; }

static fmi3Instance instantiate(const char *function, fmi3String instanceName, fmi3String instantiationToken,
                                fmi3String resourcePath, fmi3Boolean loggingOn, bool co_simulation,
                                bool event_mode_used, fmi3InstanceEnvironment environment,
                                fmi3LogMessageCallback logMessage) {
    Fmi3Instance host; /* a stand-in so that errors before allocation still reach the logger */
    memset(&host, 0, sizeof host);
    host.environment = environment;
    host.log_message = logMessage;
    Instance *probe = &host.inst;
    probe->name = (char *)(instanceName ? instanceName : MODEL_IDENTIFIER);
    if (!instanceName || !*instanceName) {
        log_error(probe, "%s: missing instance name", function);
        return NULL;
    }
    for (int k = 0; k < N_REAL; k++) probe->start[k] = REAL_INFO[k].start;
    if (!instantiationToken) {
        log_error(probe, "%s: missing instantiationToken", function);
        return NULL;
    }
    if (strcmp(instantiationToken, MODEL_GUID) != 0 &&
        !start_values_accept_path(probe, instantiationToken, resourcePath)) {
        log_error(probe, "%s: instantiationToken %s does not match this binary's %s (rebuild the FMU)", function,
                  instantiationToken, MODEL_GUID);
        return NULL;
    }
    Fmi3Instance *self = calloc(1, sizeof *self);
    const size_t name_size = strlen(instanceName) + 1;
    char *name = calloc(name_size, 1);
    if (!self || !name) {
        log_error(probe, "%s: out of memory", function);
        free(self);
        free(name);
        return NULL;
    }
    Instance *inst = &self->inst;
    memcpy(name, instanceName, name_size);
    memcpy(inst->start, probe->start, sizeof inst->start);
    inst->name = name;
    self->environment = environment;
    self->log_message = logMessage;
    inst->co_simulation = co_simulation;
    inst->event_mode_used = event_mode_used;
    inst->logging_on = loggingOn;
    inst->log_events = true;
    instance_reset(inst);
    return inst;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)visible;
    return instantiate("fmi3InstantiateModelExchange", instanceName, instantiationToken, resourcePath, loggingOn,
                       false, false, instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    /* Steps never return early and offer no intermediate variables: both are only
     * permissions and requests an FMU may ignore. */
    (void)visible, (void)earlyReturnAllowed, (void)requiredIntermediateVariables, (void)intermediateUpdate;
    if (nRequiredIntermediateVariables > 0) {
        Fmi3Instance host;
        memset(&host, 0, sizeof host);
        host.environment = instanceEnvironment;
        host.log_message = logMessage;
        host.inst.name = (char *)(instanceName ? instanceName : MODEL_IDENTIFIER);
        log_error(&host.inst, "fmi3InstantiateCoSimulation: this FMU has no intermediate variables (%zu requested)",
                  nRequiredIntermediateVariables);
        return NULL;
    }
    return instantiate("fmi3InstantiateCoSimulation", instanceName, instantiationToken, resourcePath, loggingOn,
                       true, eventModeUsed, instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn, (void)clockUpdate,
        (void)lockPreemption, (void)unlockPreemption;
    Fmi3Instance host;
    memset(&host, 0, sizeof host);
    host.environment = instanceEnvironment;
    host.log_message = logMessage;
    host.inst.name = (char *)(instanceName ? instanceName : MODEL_IDENTIFIER);
    log_error(&host.inst, "fmi3InstantiateScheduledExecution: this FMU offers Model Exchange and Co-Simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (!inst) return;
    free(inst->name);
    free(inst);
}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    CHECK("fmi3SetDebugLogging", ANY_PHASE, ANY_INTERFACE);
    return STATUS(instance_set_debug_logging(inst, "fmi3SetDebugLogging", loggingOn, nCategories, categories));
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    (void)toleranceDefined, (void)tolerance;
    CHECK("fmi3EnterInitializationMode", FMU_INSTANTIATED, ANY_INTERFACE);
    if (!instance_set_start(inst, "fmi3EnterInitializationMode", startTime, stopTimeDefined, stopTime))
        return fmi3Error;
    inst->s.phase = FMU_INITIALIZATION;
    inst->s.outputs = OUTPUTS_STALE;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    CHECK("fmi3ExitInitializationMode", FMU_INITIALIZATION, ANY_INTERFACE);
    if (!instance_exit_initialization(inst, "fmi3ExitInitializationMode")) return fmi3Error;
    inst->s.phase = inst->co_simulation && !inst->event_mode_used ? FMU_STEP_COMPLETE : FMU_EVENT_MODE;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    CHECK("fmi3EnterEventMode", FMU_STEP_COMPLETE | FMU_CONTINUOUS_MODE, ANY_INTERFACE);
    if (inst->co_simulation && !inst->event_mode_used)
        return fail(inst, "fmi3EnterEventMode: the FMU was instantiated with eventModeUsed = false");
    inst->s.phase = FMU_EVENT_MODE;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    CHECK("fmi3Terminate", RUNNING, ANY_INTERFACE);
    inst->s.phase = FMU_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    CHECK("fmi3Reset", ANY_PHASE, ANY_INTERFACE);
    instance_reset(inst);
    return fmi3OK;
}

/* ---------------------------------------------------------------- getters and setters */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    CHECK("fmi3GetFloat64", GETTABLE, ANY_INTERFACE);
    if (bad_counts(inst, "fmi3GetFloat64", nValueReferences, valueReferences, nValues, values)) return fmi3Error;
    bool table_only = true;
    for (size_t k = 0; k < nValueReferences; k++) table_only &= valueReferences[k] < N_REAL;
    if (table_only) return STATUS(instance_get_reals(inst, "fmi3GetFloat64", valueReferences, nValueReferences, values));
    /* Event indicators or time among them: each value on its own. */
    double z[N_EVENT_INDICATORS_ALLOC];
    bool have_z = false;
    for (size_t k = 0; k < nValueReferences; k++) {
        const fmi3ValueReference vr = valueReferences[k];
        if (vr >= VR_EVENT_INDICATOR_BASE && vr < VR_EVENT_INDICATOR_BASE + N_EVENT_INDICATORS) {
            if (!have_z) model_event_indicators(inst, inst->s.time, inst->s.x, z);
            have_z = true;
            values[k] = z[vr - VR_EVENT_INDICATOR_BASE];
        } else if (vr == VR_TIME) {
            values[k] = inst->s.time;
        } else if (!instance_get_reals(inst, "fmi3GetFloat64", &valueReferences[k], 1, &values[k])) {
            return fmi3Error;
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    CHECK("fmi3SetFloat64", SETTABLE, ANY_INTERFACE);
    if (bad_counts(inst, "fmi3SetFloat64", nValueReferences, valueReferences, nValues, values)) return fmi3Error;
    for (size_t k = 0; k < nValueReferences; k++) {
        const fmi3ValueReference vr = valueReferences[k];
        if (vr >= VR_EVENT_INDICATOR_BASE && vr < VR_EVENT_INDICATOR_BASE + N_EVENT_INDICATORS)
            return fail(inst, "fmi3SetFloat64: event_indicator_%u is a local variable and cannot be set",
                        vr - VR_EVENT_INDICATOR_BASE + 1);
        if (vr == VR_TIME) return fail(inst, "fmi3SetFloat64: time is the independent variable and cannot be set");
    }
    return STATUS(instance_set_reals(inst, "fmi3SetFloat64", valueReferences, nValueReferences, values));
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues) {
    CHECK("fmi3GetInt32", GETTABLE, ANY_INTERFACE);
    if (bad_counts(inst, "fmi3GetInt32", nValueReferences, valueReferences, nValues, values)) return fmi3Error;
    return STATUS(instance_get_integers(inst, "fmi3GetInt32", valueReferences, nValueReferences, values));
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues) {
    CHECK("fmi3SetInt32", SETTABLE, ANY_INTERFACE);
    if (bad_counts(inst, "fmi3SetInt32", nValueReferences, valueReferences, nValues, values)) return fmi3Error;
    return STATUS(instance_set_integers(inst, "fmi3SetInt32", valueReferences, nValueReferences, values));
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Boolean values[], size_t nValues) {
    CHECK("fmi3GetBoolean", GETTABLE, ANY_INTERFACE);
    if (bad_counts(inst, "fmi3GetBoolean", nValueReferences, valueReferences, nValues, values)) return fmi3Error;
    if (!instance_boolean_access(inst, "fmi3GetBoolean", valueReferences, nValueReferences, false)) return fmi3Error;
    for (size_t k = 0; k < nValueReferences; k++) values[k] = inst->s.b[valueReferences[k] - VR_BOOLEAN_BASE];
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Boolean values[], size_t nValues) {
    CHECK("fmi3SetBoolean", SETTABLE, ANY_INTERFACE);
    if (bad_counts(inst, "fmi3SetBoolean", nValueReferences, valueReferences, nValues, values)) return fmi3Error;
    if (!instance_boolean_access(inst, "fmi3SetBoolean", valueReferences, nValueReferences, true)) return fmi3Error;
    for (size_t k = 0; k < nValueReferences; k++) inst->s.b[valueReferences[k] - VR_BOOLEAN_BASE] = values[k];
    return fmi3OK;
}

/* The types this FMU has no variables of: a call naming a variable is refused. */
#define NO_VARIABLES_OF_TYPE(Type, CType, Const)                                                              \
    fmi3Status fmi3Get##Type(fmi3Instance instance, const fmi3ValueReference valueReferences[],              \
                             size_t nValueReferences, CType values[], size_t nValues) {                      \
        (void)values, (void)nValues;                                                                         \
        CHECK("fmi3Get" #Type, GETTABLE, ANY_INTERFACE);                                                      \
        if (nValueReferences == 0) return fmi3OK;                                                            \
        return fail(inst, "fmi3Get" #Type ": this FMU has no " #Type " variables (value reference %u)",       \
                    valueReferences ? valueReferences[0] : 0);                                               \
    }                                                                                                        \
    fmi3Status fmi3Set##Type(fmi3Instance instance, const fmi3ValueReference valueReferences[],              \
                             size_t nValueReferences, Const CType values[], size_t nValues) {                \
        (void)values, (void)nValues;                                                                         \
        CHECK("fmi3Set" #Type, SETTABLE, ANY_INTERFACE);                                                      \
        if (nValueReferences == 0) return fmi3OK;                                                            \
        return fail(inst, "fmi3Set" #Type ": this FMU has no " #Type " variables (value reference %u)",       \
                    valueReferences ? valueReferences[0] : 0);                                               \
    }

NO_VARIABLES_OF_TYPE(Float32, fmi3Float32, const)
NO_VARIABLES_OF_TYPE(Int8, fmi3Int8, const)
NO_VARIABLES_OF_TYPE(UInt8, fmi3UInt8, const)
NO_VARIABLES_OF_TYPE(Int16, fmi3Int16, const)
NO_VARIABLES_OF_TYPE(UInt16, fmi3UInt16, const)
NO_VARIABLES_OF_TYPE(UInt32, fmi3UInt32, const)
NO_VARIABLES_OF_TYPE(Int64, fmi3Int64, const)
NO_VARIABLES_OF_TYPE(UInt64, fmi3UInt64, const)
NO_VARIABLES_OF_TYPE(String, fmi3String, const)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    (void)valueSizes, (void)values, (void)nValues;
    CHECK("fmi3GetBinary", GETTABLE, ANY_INTERFACE);
    if (nValueReferences == 0) return fmi3OK;
    return fail(inst, "fmi3GetBinary: this FMU has no Binary variables (value reference %u)",
                valueReferences ? valueReferences[0] : 0);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    (void)valueSizes, (void)values, (void)nValues;
    CHECK("fmi3SetBinary", SETTABLE, ANY_INTERFACE);
    if (nValueReferences == 0) return fmi3OK;
    return fail(inst, "fmi3SetBinary: this FMU has no Binary variables (value reference %u)",
                valueReferences ? valueReferences[0] : 0);
}

/* ---------------------------------------------------------------- not provided: clocks,
 * structural parameters, partial derivatives, dependencies at run time */

static fmi3Status not_provided(fmi3Instance instance, const char *function, const char *why) {
    CHECK(function, ANY_PHASE, ANY_INTERFACE);
    return fail(inst, "%s: not provided (%s)", function, why);
}

#define NO_CLOCKS "this FMU has no clocks"

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    (void)valueReferences, (void)nValueReferences, (void)values;
    return not_provided(instance, "fmi3GetClock", NO_CLOCKS);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    (void)valueReferences, (void)nValueReferences, (void)values;
    return not_provided(instance, "fmi3SetClock", NO_CLOCKS);
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals, (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalDecimal", NO_CLOCKS);
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions, (void)qualifiers;
    return not_provided(instance, "fmi3GetIntervalFraction", NO_CLOCKS);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return not_provided(instance, "fmi3GetShiftDecimal", NO_CLOCKS);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, "fmi3GetShiftFraction", NO_CLOCKS);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals;
    return not_provided(instance, "fmi3SetIntervalDecimal", NO_CLOCKS);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, "fmi3SetIntervalFraction", NO_CLOCKS);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return not_provided(instance, "fmi3SetShiftDecimal", NO_CLOCKS);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return not_provided(instance, "fmi3SetShiftFraction", NO_CLOCKS);
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    return not_provided(instance, "fmi3EvaluateDiscreteStates", NO_CLOCKS);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference, (void)activationTime;
    return not_provided(instance, "fmi3ActivateModelPartition", "no Scheduled Execution");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterConfigurationMode", "this FMU has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3ExitConfigurationMode", "this FMU has no structural parameters");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference, (void)nDependencies;
    return not_provided(instance, "fmi3GetNumberOfVariableDependencies", "the model description declares them");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents,
        (void)dependencyKinds, (void)nDependencies;
    return not_provided(instance, "fmi3GetVariableDependencies", "the model description declares them");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity,
        (void)nSensitivity;
    return not_provided(instance, "fmi3GetDirectionalDerivative", "providesDirectionalDerivatives=false");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity,
        (void)nSensitivity;
    return not_provided(instance, "fmi3GetAdjointDerivative", "providesAdjointDerivatives=false");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)orders, (void)values, (void)nValues;
    return not_provided(instance, "fmi3GetOutputDerivatives", "maxOutputDerivativeOrder=0");
}

/* ---------------------------------------------------------------- FMU state */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    CHECK("fmi3GetFMUState", ANY_PHASE, ANY_INTERFACE);
    if (!FMUState) return fail(inst, "fmi3GetFMUState: NULL state pointer");
    DynamicState *copy = (DynamicState *)*FMUState;
    if (!copy) copy = calloc(1, sizeof *copy);
    if (!copy) return fail(inst, "fmi3GetFMUState: out of memory");
    *copy = inst->s;
    *FMUState = copy;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    CHECK("fmi3SetFMUState", ANY_PHASE, ANY_INTERFACE);
    if (!FMUState) return fail(inst, "fmi3SetFMUState: NULL state");
    inst->s = *(const DynamicState *)FMUState;
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    CHECK("fmi3FreeFMUState", ANY_PHASE, ANY_INTERFACE);
    if (!FMUState || !*FMUState) return fmi3OK;
    free(*FMUState);
    *FMUState = NULL;
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    CHECK("fmi3SerializedFMUStateSize", ANY_PHASE, ANY_INTERFACE);
    if (!FMUState || !size) return fail(inst, "fmi3SerializedFMUStateSize: NULL argument");
    *size = instance_serialized_size();
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    CHECK("fmi3SerializeFMUState", ANY_PHASE, ANY_INTERFACE);
    if (!FMUState || !serializedState) return fail(inst, "fmi3SerializeFMUState: NULL argument");
    return STATUS(instance_serialize(inst, "fmi3SerializeFMUState", (const DynamicState *)FMUState, serializedState,
                                     size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    CHECK("fmi3DeserializeFMUState", ANY_PHASE, ANY_INTERFACE);
    if (!serializedState || !FMUState) return fail(inst, "fmi3DeserializeFMUState: NULL argument");
    DynamicState in;
    if (!instance_deserialize(inst, "fmi3DeserializeFMUState", serializedState, size, &in)) return fmi3Error;
    DynamicState *copy = (DynamicState *)*FMUState;
    if (!copy) copy = calloc(1, sizeof *copy);
    if (!copy) return fail(inst, "fmi3DeserializeFMUState: out of memory");
    *copy = in;
    *FMUState = copy;
    return fmi3OK;
}

/* ---------------------------------------------------------------- events (both interfaces) */

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    CHECK("fmi3UpdateDiscreteStates", FMU_EVENT_MODE, ANY_INTERFACE);
    if (!discreteStatesNeedUpdate || !terminateSimulation || !nominalsOfContinuousStatesChanged ||
        !valuesOfContinuousStatesChanged || !nextEventTimeDefined || !nextEventTime)
        return fail(inst, "fmi3UpdateDiscreteStates: NULL argument");
    bool states_changed = false;
    double next_event = INFINITY;
    if (!instance_update_discrete_states(inst, "fmi3UpdateDiscreteStates", &states_changed, &next_event))
        return fmi3Error;
    *discreteStatesNeedUpdate = fmi3False;
    *terminateSimulation = fmi3False;
    *nominalsOfContinuousStatesChanged = fmi3False;
    *valuesOfContinuousStatesChanged = states_changed;
    *nextEventTimeDefined = isfinite(next_event);
    *nextEventTime = isfinite(next_event) ? next_event : 0.0;
    return fmi3OK;
}

/* ---------------------------------------------------------------- Co-Simulation */

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    CHECK("fmi3EnterStepMode", FMU_EVENT_MODE, ONLY_CO_SIMULATION);
    inst->s.phase = FMU_STEP_COMPLETE;
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK("fmi3DoStep", FMU_STEP_COMPLETE, ONLY_CO_SIMULATION);
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return fail(inst, "fmi3DoStep: NULL argument");
    if (!instance_do_step(inst, "fmi3DoStep", currentCommunicationPoint, communicationStepSize)) return fmi3Error;
    /* A time event on the end point: with event mode the importer takes it in Event Mode,
     * with the inputs of this instant; without, the next step does (as in FMI 2.0). */
    *eventHandlingNeeded = inst->event_mode_used && inst->time_events && instance_time_event_due(inst);
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = inst->s.time;
    return fmi3OK;
}

/* ---------------------------------------------------------------- Model Exchange */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    CHECK("fmi3EnterContinuousTimeMode", FMU_EVENT_MODE, ONLY_MODEL_EXCHANGE);
    inst->s.phase = FMU_CONTINUOUS_MODE;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK("fmi3CompletedIntegratorStep", FMU_CONTINUOUS_MODE, ONLY_MODEL_EXCHANGE);
    if (!enterEventMode || !terminateSimulation) return fail(inst, "fmi3CompletedIntegratorStep: NULL argument");
    /* A safety net: an indicator that is negative now means an event was stepped over. */
    *enterEventMode = instance_event_indicator_crossed(inst);
    *terminateSimulation = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    CHECK("fmi3SetTime", ME_SIM, ONLY_MODEL_EXCHANGE);
    return STATUS(instance_set_time(inst, "fmi3SetTime", time));
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    CHECK("fmi3SetContinuousStates", FMU_CONTINUOUS_MODE, ONLY_MODEL_EXCHANGE);
    return STATUS(instance_set_states(inst, "fmi3SetContinuousStates", continuousStates, nContinuousStates));
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    CHECK("fmi3GetContinuousStateDerivatives", GETTABLE & ~FMU_INITIALIZATION, ONLY_MODEL_EXCHANGE);
    if (!instance_check_count(inst, "fmi3GetContinuousStateDerivatives", derivatives, nContinuousStates, N_STATES,
                              "derivatives"))
        return fmi3Error;
    model_derivatives(inst, inst->s.time, inst->s.x, derivatives);
    return fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    CHECK("fmi3GetEventIndicators", GETTABLE & ~FMU_INITIALIZATION, ONLY_MODEL_EXCHANGE);
    if (!instance_check_count(inst, "fmi3GetEventIndicators", eventIndicators, nEventIndicators, N_EVENT_INDICATORS,
                              "event indicators"))
        return fmi3Error;
    model_event_indicators(inst, inst->s.time, inst->s.x, eventIndicators);
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    CHECK("fmi3GetContinuousStates", GETTABLE & ~FMU_INITIALIZATION, ONLY_MODEL_EXCHANGE);
    if (!instance_check_count(inst, "fmi3GetContinuousStates", continuousStates, nContinuousStates, N_STATES,
                              "states"))
        return fmi3Error;
    memcpy(continuousStates, inst->s.x, N_STATES * sizeof(double));
    return fmi3OK;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates) {
    CHECK("fmi3GetNominalsOfContinuousStates", ANY_PHASE & ~FMU_ERROR, ONLY_MODEL_EXCHANGE);
    if (!instance_check_count(inst, "fmi3GetNominalsOfContinuousStates", nominals, nContinuousStates, N_STATES,
                              "nominals"))
        return fmi3Error;
    for (size_t k = 0; k < nContinuousStates; k++) nominals[k] = 1.0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    CHECK("fmi3GetNumberOfEventIndicators", ANY_PHASE, ANY_INTERFACE);
    if (!nEventIndicators) return fail(inst, "fmi3GetNumberOfEventIndicators: NULL argument");
    *nEventIndicators = N_EVENT_INDICATORS;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    CHECK("fmi3GetNumberOfContinuousStates", ANY_PHASE, ANY_INTERFACE);
    if (!nContinuousStates) return fail(inst, "fmi3GetNumberOfContinuousStates: NULL argument");
    *nContinuousStates = N_STATES;
    return fmi3OK;
}
