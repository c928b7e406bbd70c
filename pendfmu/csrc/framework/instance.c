/* What the FMI 2.0 and FMI 3.0 facades do with an instance, whatever their version.
 *
 * A facade (fmi2_api.c, fmi3_api.c) checks the instance pointer and the call-sequence
 * phase, converts its version's types and statuses, and calls these. Everything that
 * decides a value lives here, once: getting and setting with their checks, leaving
 * initialization, a Co-Simulation step with its time events, an event update, the lazy
 * outputs, serialized FMU states. Why: the two versions of a component then run the same
 * code on the same data, and give the same trajectories to the bit.
 *
 * A failing function logs its reason (through the facade's log_error), puts the instance
 * into FMU_ERROR and returns false.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "framework.h"

#define STATE_MAGIC "pendfmu-state-v1"
#define ANY_PHASE 0x7F

bool instance_fail(Instance *inst, const char *format, ...) {
    char message[1024];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    log_error(inst, "%s", message);
    inst->s.phase = FMU_ERROR;
    return false;
}

/* ---------------------------------------------------------------- time events and outputs */

/* How far from the current time a time event still counts as "now". */
static double time_event_window(const Instance *inst, double t) {
    const double tolerance = TIME_EVENT_TOLERANCE * fmax(1.0, fabs(t));
    return inst->co_simulation ? fmax(tolerance, model_time_event_window(inst)) : tolerance;
}

bool instance_time_event_due(const Instance *inst) {
    const double t = inst->s.time;
    return model_next_time_event(inst) <= t + time_event_window(inst, t);
}

/* Take every time event due at the current time (inputs evaluated there). Returns false
 * (logged) when they do not end: events closer than the time tolerance. */
static bool take_due_time_events(Instance *inst) {
    for (int k = 0; instance_time_event_due(inst); k++) {
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
 * set at this point. The event itself is taken when the next step leaves the point (or, in
 * FMI 3.0 with event mode, by the event update there), so that inputs set after a step are
 * the ones the sample sees. */
static void compute_outputs(Instance *inst) {
    model_outputs(inst, inst->s.time, inst->s.x);
    if (inst->time_events && inst->co_simulation && instance_time_event_due(inst))
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
static bool reads_computed_outputs(const unsigned vr[], size_t nvr) {
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

/* ---------------------------------------------------------------- life cycle */

void instance_reset(Instance *inst) {
    memset(&inst->s, 0, sizeof inst->s);
    for (int k = 0; k < N_REAL; k++) inst->s.r[k] = inst->start[k];
    for (int k = 0; k < N_INTEGER; k++) inst->s.i[k] = INTEGER_INFO[k].start;
    for (int k = 0; k < N_BOOLEAN; k++) inst->s.b[k] = BOOLEAN_INFO[k].start != 0;
    inst->s.phase = FMU_INSTANTIATED;
}

bool instance_set_debug_logging(Instance *inst, const char *function, bool on, size_t n,
                                const char *const categories[]) {
    bool events = n == 0;
    for (size_t k = 0; k < n; k++) {
        if (!categories || !categories[k]) return instance_fail(inst, "%s: NULL category", function);
        if (strcmp(categories[k], "logEvents") == 0) events = true;
        else if (strcmp(categories[k], "logStatusError") != 0)
            return instance_fail(inst, "%s: unknown log category '%s' (known: logEvents, logStatusError)", function,
                                 categories[k]);
    }
    inst->logging_on = on;
    inst->log_events = events;
    return true;
}

bool instance_set_start(Instance *inst, const char *function, double start, bool stop_defined, double stop) {
    if (!isfinite(start)) return instance_fail(inst, "%s: start time %g is not finite", function, start);
    if (stop_defined && !(stop >= start))
        return instance_fail(inst, "%s: stop time %g before start time %g", function, stop, start);
    inst->s.time = start;
    return true;
}

bool instance_exit_initialization(Instance *inst, const char *function) {
    char why[512];
    if (!model_check_parameters(inst, why, sizeof why)) return instance_fail(inst, "%s", why);
    if (!solver_initialize(inst)) return instance_fail(inst, "%s: initialization failed", function);
    /* A continuous model (no time event) skips the time-event bookkeeping of every step: a
     * step of the rig's cart costs some 70 ns, and that bookkeeping a fifth of it. */
    inst->time_events = isfinite(model_next_time_event(inst));
    compute_outputs(inst);
    inst->s.outputs = OUTPUTS_CURRENT;
    return true;
}

/* ---------------------------------------------------------------- getters */

bool instance_get_reals(Instance *inst, const char *function, const unsigned vr[], size_t nvr, double value[]) {
    const bool current = inst->s.outputs == OUTPUTS_CURRENT ||
                         (inst->s.outputs == OUTPUTS_STEPPED && !reads_computed_outputs(vr, nvr));
    if (inst->s.phase != FMU_ERROR && !current && !update_outputs(inst))
        return instance_fail(inst, "%s: cannot compute outputs", function);
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] >= N_REAL) return instance_fail(inst, "%s: unknown value reference %u", function, vr[k]);
        value[k] = inst->s.r[vr[k]];
    }
    return true;
}

bool instance_get_integers(Instance *inst, const char *function, const unsigned vr[], size_t nvr, int value[]) {
    if (inst->s.phase != FMU_ERROR && !update_outputs(inst))
        return instance_fail(inst, "%s: cannot compute outputs", function);
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] < VR_INTEGER_BASE || vr[k] >= VR_INTEGER_BASE + N_INTEGER)
            return instance_fail(inst, "%s: unknown value reference %u", function, vr[k]);
        value[k] = inst->s.i[vr[k] - VR_INTEGER_BASE];
    }
    return true;
}

/* ---------------------------------------------------------------- setters */

/* May a variable of this causality be set in the instance's current phase? Inputs from
 * instantiation on: FMI 2.0 and 3.0 let an importer set every variable that has a start
 * value before initialization, inputs included (fmpy's start_values, an SSV value on an
 * input), and the value set there is the one initialization computes with. Every input of
 * these FMUs is continuous, so no phase after it is closed to them either. */
static bool settable(const Instance *inst, Causality causality) {
    const FmuPhase phase = inst->s.phase;
    if (causality == CAUSALITY_PARAMETER) return phase & (FMU_INSTANTIATED | FMU_INITIALIZATION);
    if (causality == CAUSALITY_INPUT)
        return phase & (FMU_INSTANTIATED | FMU_INITIALIZATION | FMU_STEP_COMPLETE | FMU_EVENT_MODE |
                        FMU_CONTINUOUS_MODE);
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

static bool refuse_set(Instance *inst, const char *function, const char *name, Causality causality) {
    if (causality == CAUSALITY_OUTPUT || causality == CAUSALITY_LOCAL)
        return instance_fail(inst, "%s: %s is an %s variable and cannot be set", function, name,
                             causality_name(causality));
    if (causality == CAUSALITY_PARAMETER)
        return instance_fail(inst, "%s: parameter %s can only be set after instantiation or in initialization mode "
                             "(phase is '%s')", function, name, phase_name(inst->s.phase));
    return instance_fail(inst, "%s: input %s cannot be set in phase '%s'", function, name, phase_name(inst->s.phase));
}

static bool in_range(const RealInfo *info, double value) {
    if (info->has_low && (value < info->low || (info->low_open && value == info->low))) return false;
    if (info->has_high && value > info->high) return false;
    return true;
}

/* Whether a variable the importer sets (a parameter or an input) may hold this value: finite
 * and inside its physical range. The setters and the check of a restored state ask this one
 * question, so a state holds only what a setter could have put there, in any phase. */
static bool settable_value(const RealInfo *info, double value) { return isfinite(value) && in_range(info, value); }

bool instance_set_reals(Instance *inst, const char *function, const unsigned vr[], size_t nvr, const double value[]) {
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] >= N_REAL) return instance_fail(inst, "%s: unknown value reference %u", function, vr[k]);
        const RealInfo *info = &REAL_INFO[vr[k]];
        if (!settable(inst, info->causality)) return refuse_set(inst, function, info->name, info->causality);
        if (!isfinite(value[k]))
            return instance_fail(inst, "%s: %s = %g is not a finite number", function, info->name, value[k]);
        if (!in_range(info, value[k]))
            return instance_fail(inst, "%s: %s = %g is outside its physical range %s%g, %g%s", function, info->name,
                                 value[k], info->low_open || !info->has_low ? "(" : "[",
                                 info->has_low ? info->low : -INFINITY, info->has_high ? info->high : INFINITY,
                                 info->has_high ? "]" : ")");
    }
    for (size_t k = 0; k < nvr; k++) {
        inst->s.r[vr[k]] = value[k];
        inst->s.u_base[vr[k]] = value[k];
    }
    if (nvr > 0) inst->s.outputs = OUTPUTS_STALE;
    return true;
}

bool instance_set_integers(Instance *inst, const char *function, const unsigned vr[], size_t nvr, const int value[]) {
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] < VR_INTEGER_BASE || vr[k] >= VR_INTEGER_BASE + N_INTEGER)
            return instance_fail(inst, "%s: unknown value reference %u", function, vr[k]);
        const DiscreteInfo *info = &INTEGER_INFO[vr[k] - VR_INTEGER_BASE];
        if (!settable(inst, info->causality)) return refuse_set(inst, function, info->name, info->causality);
    }
    /* Integer parameters have no table range: model_check_parameters judges them. */
    for (size_t k = 0; k < nvr; k++) inst->s.i[vr[k] - VR_INTEGER_BASE] = value[k];
    if (nvr > 0) inst->s.outputs = OUTPUTS_STALE;
    return true;
}

bool instance_boolean_access(Instance *inst, const char *function, const unsigned vr[], size_t nvr, bool set) {
    if (!set && inst->s.phase != FMU_ERROR && !update_outputs(inst))
        return instance_fail(inst, "%s: cannot compute outputs", function);
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] < VR_BOOLEAN_BASE || vr[k] >= VR_BOOLEAN_BASE + N_BOOLEAN)
            return instance_fail(inst, "%s: unknown value reference %u", function, vr[k]);
        const DiscreteInfo *info = &BOOLEAN_INFO[vr[k] - VR_BOOLEAN_BASE];
        if (set && !settable(inst, info->causality)) return refuse_set(inst, function, info->name, info->causality);
    }
    if (set && nvr > 0) inst->s.outputs = OUTPUTS_STALE;
    return true;
}

/* ---------------------------------------------------------------- Co-Simulation step */

bool instance_do_step(Instance *inst, const char *function, double t, double h) {
    DynamicState *s = &inst->s;
    if (!isfinite(t) || !isfinite(h) || h < 0.0)
        return instance_fail(inst, "%s: invalid step from t = %g of size %g", function, t, h);
    if (fabs(t - s->time) > 1e-9 * fmax(1.0, fabs(s->time)))
        return instance_fail(inst, "%s: step starts at t = %.12g but the FMU is at t = %.12g", function, t, s->time);
    s->time = t;
    /* Input derivatives apply to the step that starts where they were set. */
    const bool had_derivatives = s->uder_set && s->uder_time == s->time;
    if (s->uder_set && !had_derivatives) s->uder_set = false;
    if (had_derivatives)
        for (int j = 0; j < N_INPUTS; j++) s->u_base[INPUT_VR[j]] = s->r[INPUT_VR[j]];
    /* Time events: one due at the start point is taken now, with the inputs the master set
     * there; one inside the step with the inputs interpolated (or held) to it, the states
     * integrated up to it first; one at the end point is left to the next step, which sees
     * the inputs of that point (meanwhile the outputs preview it: compute_outputs). */
    const double t_end = t + h;
    if (inst->time_events && h > 0.0 && !take_due_time_events(inst))
        return instance_fail(inst, "%s: step from t = %.12g failed", function, t);
    double events = 0.0;
    for (double t_event = inst->time_events ? model_next_time_event(inst) : INFINITY;
         inst->time_events && t_event < t_end - time_event_window(inst, t_end);
         t_event = model_next_time_event(inst)) {
        if (++events > MAX_INTERNAL_STEPS)
            return instance_fail(inst, "%s: a step of %g s holds more than %.0f time events (samples): take shorter "
                                 "steps", function, h, MAX_INTERNAL_STEPS);
        if (t_event > s->time && !solver_do_step(inst, t_event))
            return instance_fail(inst, "%s: step from t = %.12g failed", function, t);
        s->time = fmax(s->time, t_event);
        if (!take_due_time_events(inst)) return instance_fail(inst, "%s: step from t = %.12g failed", function, t);
    }
    if (!solver_do_step(inst, t_end)) return instance_fail(inst, "%s: step from t = %.12g failed", function, t);
    s->uder_set = false;
    for (int j = 0; j < N_INPUTS; j++) s->u_base[INPUT_VR[j]] = s->r[INPUT_VR[j]];
    for (int j = 0; j < N_STATES; j++) s->r[STATE_VR[j]] = s->x[j];
    s->outputs = OUTPUTS_STEPPED;
    return true;
}

/* ---------------------------------------------------------------- events */

bool instance_update_discrete_states(Instance *inst, const char *function, bool *states_changed,
                                     double *next_event_time) {
    double before[N_STATES_ALLOC];
    memcpy(before, inst->s.x, sizeof before);
    if (!solver_event_iteration(inst, inst->s.time)) return instance_fail(inst, "%s: event iteration failed", function);
    *states_changed = memcmp(before, inst->s.x, sizeof before) != 0;
    if (!take_due_time_events(inst)) return instance_fail(inst, "%s: time events failed", function);
    *next_event_time = model_next_time_event(inst);
    inst->s.outputs = OUTPUTS_STALE;
    return true;
}

bool instance_event_indicator_crossed(const Instance *inst) {
    double z[N_EVENT_INDICATORS_ALLOC];
    model_event_indicators(inst, inst->s.time, inst->s.x, z);
    bool crossed = false;
    for (int k = 0; k < N_EVENT_INDICATORS; k++) crossed |= z[k] < 0.0;
    return crossed;
}

/* ---------------------------------------------------------------- Model Exchange */

bool instance_set_time(Instance *inst, const char *function, double time) {
    if (!isfinite(time)) return instance_fail(inst, "%s: time %g is not finite", function, time);
    inst->s.time = time;
    inst->s.outputs = OUTPUTS_STALE;
    return true;
}

bool instance_check_count(Instance *inst, const char *function, const void *array, size_t n, int expected,
                          const char *what) {
    if ((n > 0 && !array) || n != (size_t)expected)
        return instance_fail(inst, "%s: %zu %s given, %d expected", function, n, what, expected);
    return true;
}

bool instance_set_states(Instance *inst, const char *function, const double x[], size_t nx) {
    if (!instance_check_count(inst, function, x, nx, N_STATES, "states")) return false;
    for (size_t k = 0; k < nx; k++)
        if (!isfinite(x[k]))
            return instance_fail(inst, "%s: state %s = %g is not finite", function, REAL_INFO[STATE_VR[k]].name, x[k]);
    memcpy(inst->s.x, x, N_STATES * sizeof(double));
    inst->s.outputs = OUTPUTS_STALE;
    return true;
}

/* ---------------------------------------------------------------- serialized FMU states */

typedef struct {
    char magic[sizeof STATE_MAGIC];
    char guid[sizeof MODEL_GUID];
    DynamicState s;
} SerializedState;

size_t instance_serialized_size(void) { return sizeof(SerializedState); }

bool instance_serialize(Instance *inst, const char *function, const DynamicState *state, unsigned char *bytes,
                        size_t size) {
    if (size < sizeof(SerializedState))
        return instance_fail(inst, "%s: buffer of %zu bytes, %zu needed", function, size, sizeof(SerializedState));
    SerializedState out;
    memset(&out, 0, sizeof out);
    memcpy(out.magic, STATE_MAGIC, sizeof out.magic);
    memcpy(out.guid, MODEL_GUID, sizeof out.guid);
    out.s = *state;
    memcpy(bytes, &out, sizeof out);
    return true;
}

/* Whether a state read from bytes is one this FMU could have saved: the right GUID alone
 * does not make the bytes safe (a file edited or damaged after serializing), and the
 * values below index arrays or bound loops. The time, the interpolation orders, the
 * outputs' status, every parameter and input as a setter would take it (finite, inside its
 * physical range: an input may be set from instantiation on, so a state of any phase holds
 * one) and the model's own parameter check (e.g. the Controller's delay, an index into its
 * delay line). */
static bool state_consistent(Instance *inst, const DynamicState *s, char *why, size_t size) {
    if (!isfinite(s->time)) {
        snprintf(why, size, "time %g", s->time);
        return false;
    }
    if (s->outputs != OUTPUTS_STALE && s->outputs != OUTPUTS_STEPPED && s->outputs != OUTPUTS_CURRENT) {
        snprintf(why, size, "outputs status %d", (int)s->outputs);
        return false;
    }
    for (int vr = 0; vr < N_REAL; vr++) {
        const RealInfo *info = &REAL_INFO[vr];
        if (s->uder_order[vr] < 0 || s->uder_order[vr] > MAX_INPUT_ORDER) {
            snprintf(why, size, "input derivative order %d of %s", s->uder_order[vr], info->name);
            return false;
        }
        const bool input = info->causality == CAUSALITY_INPUT;  /* u_base: where its interpolation starts */
        if ((input || info->causality == CAUSALITY_PARAMETER) &&
            !(settable_value(info, s->r[vr]) && (!input || isfinite(s->u_base[vr])))) {
            snprintf(why, size, "%s %s = %g is not finite or outside its physical range",
                     causality_name(info->causality), info->name, s->r[vr]);
            return false;
        }
    }
    const DynamicState saved = inst->s;
    inst->s = *s;  /* the model's check reads the instance's state */
    const bool fine = model_check_parameters(inst, why, size);
    inst->s = saved;
    return fine;
}

bool instance_deserialize(Instance *inst, const char *function, const unsigned char *bytes, size_t size,
                          DynamicState *state) {
    SerializedState in;
    if (size != sizeof in)
        return instance_fail(inst, "%s: %zu bytes given, a %s state has %zu", function, size, MODEL_IDENTIFIER,
                             sizeof in);
    memcpy(&in, bytes, sizeof in);
    if (memcmp(in.magic, STATE_MAGIC, sizeof in.magic) != 0 || memcmp(in.guid, MODEL_GUID, sizeof in.guid) != 0)
        return instance_fail(inst, "%s: the bytes are not a state of this %s FMU (GUID differs)", function,
                             MODEL_IDENTIFIER);
    if (in.s.phase & ~ANY_PHASE || in.s.phase == 0)
        return instance_fail(inst, "%s: corrupt state (phase %d)", function, (int)in.s.phase);
    char why[256];
    if (!state_consistent(inst, &in.s, why, sizeof why)) return instance_fail(inst, "%s: corrupt state: %s", function, why);
    *state = in.s;
    return true;
}
