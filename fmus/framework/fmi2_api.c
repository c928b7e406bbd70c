/* Every fmi2 function of the FMI 2.0 standard, for Co-Simulation and Model Exchange.
 *
 * Each function first checks the instance pointer and that it is called in a phase of the
 * call sequence that allows it (a bit mask per function). Any failure logs its reason
 * through the host's logger and returns fmi2Error; the instance then enters the error
 * phase, from which only fmi2Reset, fmi2SetFMUstate, fmi2FreeInstance and the getters
 * lead on (FMI 2.0, section 2.1.3).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "framework.h"

#define ANY_PHASE 0x7F
#define ME_SIM (FMU_EVENT_MODE | FMU_CONTINUOUS_MODE)
#define RUNNING (FMU_STEP_COMPLETE | ME_SIM)
#define GETTABLE (FMU_INITIALIZATION | RUNNING | FMU_TERMINATED | FMU_ERROR)
#define STATE_MAGIC "pendfmu-state-v1"

/* ---------------------------------------------------------------- logging */

static void log_message(const Instance *inst, fmi2Status status, const char *category,
                        const char *format, va_list args) {
    if (!inst || !inst->cb.logger) return;
    char message[1024];
    vsnprintf(message, sizeof message, format, args);
    inst->cb.logger(inst->cb.componentEnvironment, inst->name, status, category, "%s", message);
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

static const char *phase_name(FmuPhase phase) {
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
    if ((int)only >= 0 && inst->type != only) {
        fail(inst, "%s is not available in %s", function,
             inst->type == fmi2CoSimulation ? "Co-Simulation" : "Model Exchange");
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

/* ---------------------------------------------------------------- outputs */

/* Whether a time event falls on the instance's current time and is not yet taken. */
static double time_event_window(const Instance *inst, double t) {
    const double tolerance = TIME_EVENT_TOLERANCE * fmax(1.0, fabs(t));
    return inst->type == fmi2CoSimulation ? fmax(tolerance, model_time_event_window(inst)) : tolerance;
}

static bool time_event_due(const Instance *inst) {
    const double t = inst->s.time;
    return model_next_time_event(inst) <= t + time_event_window(inst, t);
}

/* Take every time event due at the current time (inputs evaluated there). Returns false
 * (logged) when they do not end: events closer than the time tolerance. */
static bool take_due_time_events(Instance *inst) {
    for (int k = 0; time_event_due(inst); k++) {
        if (k >= MAX_EVENT_ITERATIONS) {
            log_error(inst, "t = %.12g s: more than %d time events at one instant (events closer than %g s)",
                      inst->s.time, MAX_EVENT_ITERATIONS, TIME_EVENT_TOLERANCE * fmax(1.0, fabs(inst->s.time)));
            return false;
        }
        solver_inputs_at(inst, inst->s.time);
        model_time_event(inst, inst->s.time, true);
    }
    return true;
}

/* Compute outputs and locals. In Co-Simulation, a time event on the current communication
 * point that the FMU has not taken yet (the sample at the end of the last step, or at the
 * start time) is previewed: the outputs are those of the event with the inputs the master has
 * set at this point. The event itself is taken when the next step leaves the point, so that
 * inputs set after a step are the ones the sample sees. */
static void compute_outputs(Instance *inst) {
    model_outputs(inst, inst->s.time, inst->s.x);
    if (inst->time_events && inst->type == fmi2CoSimulation && time_event_due(inst))
        model_time_event(inst, inst->s.time, false);
}

/* Bring outputs up to date. Between Co-Simulation steps an input may have changed since
 * the last step: the mode is made consistent first, as the next step would. */
static bool update_outputs(Instance *inst) {
    if (inst->s.outputs == OUTPUTS_CURRENT) return true;
    if (inst->s.outputs == OUTPUTS_STALE) {
        if (inst->s.phase == FMU_INITIALIZATION || inst->s.phase == FMU_INSTANTIATED) {
            if (!solver_initialize(inst)) return false;
        } else if (inst->s.phase == FMU_STEP_COMPLETE) {
            if (!solver_event_iteration(inst, inst->s.time)) return false;
        }
    }
    compute_outputs(inst);
    inst->s.outputs = OUTPUTS_CURRENT;
    return true;
}

/* Whether reading these Reals needs model_outputs: an output or local that is not a state.
 * Why: a master typically reads a few outputs after each step (the pendulum's angle, a
 * state), and computing all the others (trigonometry, friction) at every step cost a tenth
 * of the rig's time. Parameters and inputs are always current. */
static bool reads_computed_outputs(const fmi2ValueReference vr[], size_t nvr) {
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] >= N_REAL) continue; /* reported by the caller */
        const Causality causality = REAL_INFO[vr[k]].causality;
        if (causality != CAUSALITY_OUTPUT && causality != CAUSALITY_LOCAL) continue;
        bool state = false;
        for (int j = 0; j < N_STATES; j++) state |= STATE_VR[j] == vr[k];
        if (!state) return true;
    }
    return false;
}

/* ---------------------------------------------------------------- common functions */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

static void reset_variables(Instance *inst) {
    memset(&inst->s, 0, sizeof inst->s);
    for (int k = 0; k < N_REAL; k++) inst->s.r[k] = inst->start[k];
    for (int k = 0; k < N_INTEGER; k++) inst->s.i[k] = INTEGER_INFO[k].start;
    for (int k = 0; k < N_BOOLEAN; k++) inst->s.b[k] = BOOLEAN_INFO[k].start != 0;
    inst->s.phase = FMU_INSTANTIATED;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)visible;
    if (!functions) return NULL;
    Instance probe; /* a stand-in so that errors before allocation still reach the logger */
    memset(&probe, 0, sizeof probe);
    probe.cb = *functions;
    probe.name = (char *)(instanceName ? instanceName : MODEL_IDENTIFIER);
    if (!instanceName || !*instanceName) {
        log_error(&probe, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        log_error(&probe, "fmi2Instantiate: unknown FMU type %d", (int)fmuType);
        return NULL;
    }
    for (int k = 0; k < N_REAL; k++) probe.start[k] = REAL_INFO[k].start;
    if (!fmuGUID) {
        log_error(&probe, "fmi2Instantiate: missing GUID");
        return NULL;
    }
    if (strcmp(fmuGUID, MODEL_GUID) != 0 && !start_values_accept(&probe, fmuGUID, fmuResourceLocation)) {
        log_error(&probe, "fmi2Instantiate: GUID %s does not match this binary's %s (rebuild the FMU)", fmuGUID,
                  MODEL_GUID);
        return NULL;
    }
    Instance *inst = functions->allocateMemory ? functions->allocateMemory(1, sizeof(Instance))
                                               : calloc(1, sizeof(Instance));
    const size_t name_size = strlen(instanceName) + 1;
    char *name = functions->allocateMemory ? functions->allocateMemory(name_size, 1) : calloc(name_size, 1);
    if (!inst || !name) {
        log_error(&probe, "fmi2Instantiate: out of memory");
        if (functions->freeMemory) {
            if (inst) functions->freeMemory(inst);
            if (name) functions->freeMemory(name);
        } else {
            free(inst);
            free(name);
        }
        return NULL;
    }
    memcpy(name, instanceName, name_size);
    memcpy(inst->start, probe.start, sizeof inst->start);
    inst->name = name;
    inst->cb = *functions;
    inst->type = fmuType;
    inst->logging_on = loggingOn;
    inst->log_events = true;
    reset_variables(inst);
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return;
    if (inst->cb.freeMemory) {
        inst->cb.freeMemory(inst->name);
        inst->cb.freeMemory(inst);
    } else {
        free(inst->name);
        free(inst);
    }
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    CHECK("fmi2SetDebugLogging", ANY_PHASE, ANY_TYPE);
    bool events = nCategories == 0;
    for (size_t k = 0; k < nCategories; k++) {
        if (!categories || !categories[k]) return fail(inst, "fmi2SetDebugLogging: NULL category");
        if (strcmp(categories[k], "logEvents") == 0) events = true;
        else if (strcmp(categories[k], "logStatusError") != 0)
            return fail(inst, "fmi2SetDebugLogging: unknown log category '%s' (known: logEvents, logStatusError)",
                        categories[k]);
    }
    inst->logging_on = loggingOn;
    inst->log_events = events;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    CHECK("fmi2SetupExperiment", FMU_INSTANTIATED, ANY_TYPE);
    if (!isfinite(startTime)) return fail(inst, "fmi2SetupExperiment: start time %g is not finite", startTime);
    if (stopTimeDefined && !(stopTime >= startTime))
        return fail(inst, "fmi2SetupExperiment: stop time %g before start time %g", stopTime, startTime);
    inst->s.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    CHECK("fmi2EnterInitializationMode", FMU_INSTANTIATED, ANY_TYPE);
    inst->s.phase = FMU_INITIALIZATION;
    inst->s.outputs = OUTPUTS_STALE;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    CHECK("fmi2ExitInitializationMode", FMU_INITIALIZATION, ANY_TYPE);
    char why[512];
    if (!model_check_parameters(inst, why, sizeof why)) return fail(inst, "%s", why);
    if (!solver_initialize(inst)) return fail(inst, "fmi2ExitInitializationMode: initialization failed");
    /* A continuous model (no time event) skips the time-event bookkeeping of every step: a
     * step of the rig's cart costs some 70 ns, and that bookkeeping a fifth of it. */
    inst->time_events = isfinite(model_next_time_event(inst));
    compute_outputs(inst);
    inst->s.outputs = OUTPUTS_CURRENT;
    inst->s.phase = inst->type == fmi2CoSimulation ? FMU_STEP_COMPLETE : FMU_EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK("fmi2Terminate", RUNNING, ANY_TYPE);
    inst->s.phase = FMU_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    CHECK("fmi2Reset", ANY_PHASE, ANY_TYPE);
    reset_variables(inst);
    return fmi2OK;
}

/* ---------------------------------------------------------------- getters */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    CHECK("fmi2GetReal", GETTABLE, ANY_TYPE);
    if (null_arrays(inst, "fmi2GetReal", nvr, vr, value)) return fmi2Error;
    const bool current = inst->s.outputs == OUTPUTS_CURRENT ||
                         (inst->s.outputs == OUTPUTS_STEPPED && !reads_computed_outputs(vr, nvr));
    if (inst->s.phase != FMU_ERROR && !current && !update_outputs(inst))
        return fail(inst, "fmi2GetReal: cannot compute outputs");
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] >= N_REAL) return fail(inst, "fmi2GetReal: unknown value reference %u", vr[k]);
        value[k] = inst->s.r[vr[k]];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    CHECK("fmi2GetInteger", GETTABLE, ANY_TYPE);
    if (null_arrays(inst, "fmi2GetInteger", nvr, vr, value)) return fmi2Error;
    if (inst->s.phase != FMU_ERROR && !update_outputs(inst)) return fail(inst, "fmi2GetInteger: cannot compute outputs");
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] < VR_INTEGER_BASE || vr[k] >= VR_INTEGER_BASE + N_INTEGER)
            return fail(inst, "fmi2GetInteger: unknown value reference %u", vr[k]);
        value[k] = inst->s.i[vr[k] - VR_INTEGER_BASE];
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    CHECK("fmi2GetBoolean", GETTABLE, ANY_TYPE);
    if (null_arrays(inst, "fmi2GetBoolean", nvr, vr, value)) return fmi2Error;
    if (inst->s.phase != FMU_ERROR && !update_outputs(inst)) return fail(inst, "fmi2GetBoolean: cannot compute outputs");
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] < VR_BOOLEAN_BASE || vr[k] >= VR_BOOLEAN_BASE + N_BOOLEAN)
            return fail(inst, "fmi2GetBoolean: unknown value reference %u", vr[k]);
        value[k] = inst->s.b[vr[k] - VR_BOOLEAN_BASE];
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    CHECK("fmi2GetString", GETTABLE, ANY_TYPE);
    (void)value;
    if (nvr > 0) return fail(inst, "fmi2GetString: this FMU has no String variables (value reference %u)", vr ? vr[0] : 0);
    return fmi2OK;
}

/* ---------------------------------------------------------------- setters */

/* May a variable of this causality be set in the instance's current phase? */
static bool settable(const Instance *inst, Causality causality) {
    const FmuPhase phase = inst->s.phase;
    if (causality == CAUSALITY_PARAMETER) return phase & (FMU_INSTANTIATED | FMU_INITIALIZATION);
    if (causality == CAUSALITY_INPUT) return phase & (FMU_INITIALIZATION | RUNNING);
    return false;
}

static const char *causality_name(Causality causality) {
    switch (causality) {
    case CAUSALITY_PARAMETER: return "parameter";
    case CAUSALITY_INPUT: return "input";
    case CAUSALITY_OUTPUT: return "output";
    case CAUSALITY_LOCAL: return "local";
    }
    return "?";
}

static fmi2Status refuse_set(Instance *inst, const char *function, const char *name, Causality causality) {
    if (causality == CAUSALITY_OUTPUT || causality == CAUSALITY_LOCAL)
        return fail(inst, "%s: %s is an %s variable and cannot be set", function, name, causality_name(causality));
    if (causality == CAUSALITY_PARAMETER)
        return fail(inst, "%s: parameter %s can only be set after instantiation or in initialization mode (phase is '%s')",
                    function, name, phase_name(inst->s.phase));
    return fail(inst, "%s: input %s cannot be set in phase '%s'", function, name, phase_name(inst->s.phase));
}

static bool in_range(const RealInfo *info, double value) {
    if (info->has_low && (value < info->low || (info->low_open && value == info->low))) return false;
    if (info->has_high && value > info->high) return false;
    return true;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    CHECK("fmi2SetReal", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING, ANY_TYPE);
    if (null_arrays(inst, "fmi2SetReal", nvr, vr, value)) return fmi2Error;
    /* Check everything before changing anything: a refused call leaves the values as they were. */
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] >= N_REAL) return fail(inst, "fmi2SetReal: unknown value reference %u", vr[k]);
        const RealInfo *info = &REAL_INFO[vr[k]];
        if (!settable(inst, info->causality)) return refuse_set(inst, "fmi2SetReal", info->name, info->causality);
        if (!isfinite(value[k])) return fail(inst, "fmi2SetReal: %s = %g is not a finite number", info->name, value[k]);
        if (!in_range(info, value[k]))
            return fail(inst, "fmi2SetReal: %s = %g is outside its physical range %s%g, %g%s", info->name, value[k],
                        info->low_open || !info->has_low ? "(" : "[", info->has_low ? info->low : -INFINITY,
                        info->has_high ? info->high : INFINITY, info->has_high ? "]" : ")");
    }
    for (size_t k = 0; k < nvr; k++) {
        inst->s.r[vr[k]] = value[k];
        inst->s.u_base[vr[k]] = value[k];
    }
    if (nvr > 0) inst->s.outputs = OUTPUTS_STALE;
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    CHECK("fmi2SetInteger", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING, ANY_TYPE);
    if (null_arrays(inst, "fmi2SetInteger", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] < VR_INTEGER_BASE || vr[k] >= VR_INTEGER_BASE + N_INTEGER)
            return fail(inst, "fmi2SetInteger: unknown value reference %u", vr[k]);
        const DiscreteInfo *info = &INTEGER_INFO[vr[k] - VR_INTEGER_BASE];
        if (!settable(inst, info->causality)) return refuse_set(inst, "fmi2SetInteger", info->name, info->causality);
    }
    /* Integer parameters have no table range: model_check_parameters judges them. */
    for (size_t k = 0; k < nvr; k++) inst->s.i[vr[k] - VR_INTEGER_BASE] = value[k];
    if (nvr > 0) inst->s.outputs = OUTPUTS_STALE;
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    CHECK("fmi2SetBoolean", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING, ANY_TYPE);
    if (null_arrays(inst, "fmi2SetBoolean", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] < VR_BOOLEAN_BASE || vr[k] >= VR_BOOLEAN_BASE + N_BOOLEAN)
            return fail(inst, "fmi2SetBoolean: unknown value reference %u", vr[k]);
        const DiscreteInfo *info = &BOOLEAN_INFO[vr[k] - VR_BOOLEAN_BASE];
        if (!settable(inst, info->causality)) return refuse_set(inst, "fmi2SetBoolean", info->name, info->causality);
    }
    for (size_t k = 0; k < nvr; k++) inst->s.b[vr[k] - VR_BOOLEAN_BASE] = value[k] != fmi2False;
    if (nvr > 0) inst->s.outputs = OUTPUTS_STALE;
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    CHECK("fmi2SetString", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING, ANY_TYPE);
    (void)value;
    if (nvr > 0) return fail(inst, "fmi2SetString: this FMU has no String variables (value reference %u)", vr ? vr[0] : 0);
    return fmi2OK;
}

/* ---------------------------------------------------------------- FMU state */

typedef struct {
    char magic[sizeof STATE_MAGIC];
    char guid[sizeof MODEL_GUID];
    DynamicState s;
} SerializedState;

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK("fmi2GetFMUstate", FMU_INSTANTIATED | FMU_INITIALIZATION | RUNNING | FMU_TERMINATED | FMU_ERROR, ANY_TYPE);
    if (!FMUstate) return fail(inst, "fmi2GetFMUstate: NULL state pointer");
    DynamicState *copy = (DynamicState *)*FMUstate;
    if (!copy) {
        copy = inst->cb.allocateMemory ? inst->cb.allocateMemory(1, sizeof *copy) : calloc(1, sizeof *copy);
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
    if (inst->cb.freeMemory) inst->cb.freeMemory(*FMUstate);
    else free(*FMUstate);
    *FMUstate = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    CHECK("fmi2SerializedFMUstateSize", ANY_PHASE, ANY_TYPE);
    if (!FMUstate || !size) return fail(inst, "fmi2SerializedFMUstateSize: NULL argument");
    *size = sizeof(SerializedState);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    CHECK("fmi2SerializeFMUstate", ANY_PHASE, ANY_TYPE);
    if (!FMUstate || !serializedState) return fail(inst, "fmi2SerializeFMUstate: NULL argument");
    if (size < sizeof(SerializedState))
        return fail(inst, "fmi2SerializeFMUstate: buffer of %zu bytes, %zu needed", size, sizeof(SerializedState));
    SerializedState out;
    memset(&out, 0, sizeof out);
    memcpy(out.magic, STATE_MAGIC, sizeof out.magic);
    memcpy(out.guid, MODEL_GUID, sizeof out.guid);
    out.s = *(const DynamicState *)FMUstate;
    memcpy(serializedState, &out, sizeof out);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    CHECK("fmi2DeSerializeFMUstate", ANY_PHASE, ANY_TYPE);
    if (!serializedState || !FMUstate) return fail(inst, "fmi2DeSerializeFMUstate: NULL argument");
    SerializedState in;
    if (size != sizeof in)
        return fail(inst, "fmi2DeSerializeFMUstate: %zu bytes given, a %s state has %zu", size, MODEL_IDENTIFIER, sizeof in);
    memcpy(&in, serializedState, sizeof in);
    if (memcmp(in.magic, STATE_MAGIC, sizeof in.magic) != 0 || memcmp(in.guid, MODEL_GUID, sizeof in.guid) != 0)
        return fail(inst, "fmi2DeSerializeFMUstate: the bytes are not a state of this %s FMU (GUID differs)", MODEL_IDENTIFIER);
    if (in.s.phase & ~ANY_PHASE || in.s.phase == 0)
        return fail(inst, "fmi2DeSerializeFMUstate: corrupt state (phase %d)", (int)in.s.phase);
    DynamicState *copy = (DynamicState *)*FMUstate;
    if (!copy) {
        copy = inst->cb.allocateMemory ? inst->cb.allocateMemory(1, sizeof *copy) : calloc(1, sizeof *copy);
        if (!copy) return fail(inst, "fmi2DeSerializeFMUstate: out of memory");
    }
    *copy = in.s;
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
    DynamicState *s = &inst->s;
    if (!isfinite(currentCommunicationPoint) || !isfinite(communicationStepSize) || communicationStepSize < 0.0)
        return fail(inst, "fmi2DoStep: invalid step from t = %g of size %g", currentCommunicationPoint,
                    communicationStepSize);
    if (fabs(currentCommunicationPoint - s->time) > 1e-9 * fmax(1.0, fabs(s->time)))
        return fail(inst, "fmi2DoStep: step starts at t = %.12g but the FMU is at t = %.12g", currentCommunicationPoint,
                    s->time);
    s->time = currentCommunicationPoint;
    /* Input derivatives apply to the step that starts where they were set. */
    const bool had_derivatives = s->uder_set && s->uder_time == s->time;
    if (s->uder_set && !had_derivatives) s->uder_set = false;
    if (had_derivatives)
        for (int j = 0; j < N_INPUTS; j++) s->u_base[INPUT_VR[j]] = s->r[INPUT_VR[j]];
    /* Time events: one due at the start point is taken now, with the inputs the master set
     * there; one inside the step with the inputs interpolated (or held) to it, the states
     * integrated up to it first; one at the end point is left to the next step, which sees
     * the inputs of that point (meanwhile the outputs preview it: compute_outputs). */
    const double t_end = currentCommunicationPoint + communicationStepSize;
    if (inst->time_events && communicationStepSize > 0.0 && !take_due_time_events(inst))
        return fail(inst, "fmi2DoStep: step from t = %.12g failed", currentCommunicationPoint);
    double events = 0.0;
    for (double t_event = inst->time_events ? model_next_time_event(inst) : INFINITY;
         inst->time_events && t_event < t_end - time_event_window(inst, t_end);
         t_event = model_next_time_event(inst)) {
        if (++events > MAX_INTERNAL_STEPS)
            return fail(inst, "fmi2DoStep: a step of %g s holds more than %.0f time events (samples): take shorter "
                        "steps", communicationStepSize, MAX_INTERNAL_STEPS);
        if (t_event > s->time && !solver_do_step(inst, t_event))
            return fail(inst, "fmi2DoStep: step from t = %.12g failed", currentCommunicationPoint);
        s->time = fmax(s->time, t_event);
        if (!take_due_time_events(inst))
            return fail(inst, "fmi2DoStep: step from t = %.12g failed", currentCommunicationPoint);
    }
    if (!solver_do_step(inst, t_end))
        return fail(inst, "fmi2DoStep: step from t = %.12g failed", currentCommunicationPoint);
    s->uder_set = false;
    for (int j = 0; j < N_INPUTS; j++) s->u_base[INPUT_VR[j]] = s->r[INPUT_VR[j]];
    for (int j = 0; j < N_STATES; j++) s->r[STATE_VR[j]] = s->x[j];
    s->outputs = OUTPUTS_STEPPED;
    return fmi2OK;
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
    double before[N_STATES_ALLOC];
    memcpy(before, inst->s.x, sizeof before);
    if (!solver_event_iteration(inst, inst->s.time))
        return fail(inst, "fmi2NewDiscreteStates: event iteration failed");
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = memcmp(before, inst->s.x, sizeof before) != 0;
    if (!take_due_time_events(inst)) return fail(inst, "fmi2NewDiscreteStates: time events failed");
    const double next_event = model_next_time_event(inst);
    eventInfo->nextEventTimeDefined = isfinite(next_event) ? fmi2True : fmi2False;
    eventInfo->nextEventTime = isfinite(next_event) ? next_event : 0.0;
    inst->s.outputs = OUTPUTS_STALE;
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
    double z[N_EVENT_INDICATORS_ALLOC];
    model_event_indicators(inst, inst->s.time, inst->s.x, z);
    bool inconsistent = false;
    for (int k = 0; k < N_EVENT_INDICATORS; k++) inconsistent |= z[k] < 0.0;
    *enterEventMode = inconsistent;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    CHECK("fmi2SetTime", ME_SIM, fmi2ModelExchange);
    if (!isfinite(time)) return fail(inst, "fmi2SetTime: time %g is not finite", time);
    inst->s.time = time;
    inst->s.outputs = OUTPUTS_STALE;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    CHECK("fmi2SetContinuousStates", FMU_CONTINUOUS_MODE, fmi2ModelExchange);
    if ((nx > 0 && !x) || nx != N_STATES) return fail(inst, "fmi2SetContinuousStates: %zu states given, %d expected", nx, N_STATES);
    for (size_t k = 0; k < nx; k++)
        if (!isfinite(x[k])) return fail(inst, "fmi2SetContinuousStates: state %s = %g is not finite",
                                         REAL_INFO[STATE_VR[k]].name, x[k]);
    memcpy(inst->s.x, x, N_STATES * sizeof(double));
    inst->s.outputs = OUTPUTS_STALE;
    return fmi2OK;
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
