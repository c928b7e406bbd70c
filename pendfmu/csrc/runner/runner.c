/* A native communication loop over one Co-Simulation FMU instance.
 *
 * The loop a fit runs thousands of times: at every communication point set the inputs,
 * read the outputs, step to the next point. It calls the FMU's own fmi2 functions through
 * pointers taken from the library fmpy loaded (so the instance is fmpy's, set up and
 * parameterized by it) and does exactly what the Python loop does, in the same order, so
 * the results are bit-identical; only the per-step overhead of Python and ctypes is gone.
 */
#include "runner.h"

/* Run through n_points communication points. inputs is n_points x n_inputs (row-major),
 * outputs n_points x n_outputs; slopes (or NULL: inputs held) gives each input's first
 * derivative over the step that starts at each point. Returns -1 on success, else the
 * index of the point where an fmi2 call failed (the FMU has logged why). */
RUNNER_EXPORT
long pendfmu_run_single(const Unit *unit, size_t n_points, const double *times,
                        size_t n_inputs, const fmi2ValueReference *input_vrs, const double *inputs,
                        const double *slopes, size_t n_outputs, const fmi2ValueReference *output_vrs,
                        double *outputs) {
    fmi2Integer first_order[MAX_PORTS];
    if (n_inputs > MAX_PORTS) return 0;
    for (size_t j = 0; j < n_inputs; j++) first_order[j] = 1;
    for (size_t k = 0; k < n_points; k++) {
        if (n_inputs && unit->set_real(unit->component, input_vrs, n_inputs, inputs + k * n_inputs) > fmi2Warning)
            return (long)k;
        if (n_inputs && slopes && k + 1 < n_points &&
            unit->set_input_derivatives(unit->component, input_vrs, n_inputs, first_order,
                                        slopes + k * n_inputs) > fmi2Warning)
            return (long)k;
        if (unit->get_real(unit->component, output_vrs, n_outputs, outputs + k * n_outputs) > fmi2Warning)
            return (long)k;
        if (k + 1 < n_points &&
            unit->do_step(unit->component, times[k], times[k + 1] - times[k], fmi2True) > fmi2Warning)
            return (long)k;
    }
    return -1;
}

/* ------------------------------------------------------------------ a whole system
 *
 * The co-simulation master of pendfmu/simulator/master.py, step for step: components in
 * Gauss-Seidel groups; every connected input gets its value at t and its slope towards
 * t+h; a group whose members feed each other is torn at one signal and solved with
 * FMU-state rollback by the root finder of tear.h (or, without a single-signal tear,
 * iterated until its internal signals reproduce their guesses). The Python master stays
 * the reference: both do the same floating-point operations in the same order, so they
 * agree to the bit.
 */
#include <math.h>
#include <stdlib.h>

#include "tear.h"

#define MAX_SIGNALS 256

/* Where each unit's inputs come from, in the order set_inputs sets them (drives, then
 * links: the Python master's order), and which links each group publishes. Worked out
 * once per run instead of at every step. */
typedef struct {
    size_t n;
    unsigned char from_link[MAX_PORTS]; /* 1: links[index], 0: drives[index] */
    size_t index[MAX_PORTS];
    fmi2ValueReference vr[MAX_PORTS];
} Ports;

typedef struct {
    Ports *ports;          /* per unit */
    size_t *published;     /* links whose source is in a group, group after group */
    size_t *publish_start; /* n_groups + 1 offsets into published */
    unsigned char *coupled; /* per group: its members feed each other */
} Plan;

/* What a run keeps between steps for its tears (master.py: _previous_end, _tear_slope). */
typedef struct {
    double prediction, slope;
    int has_prediction;
} TearMemory;

static int in_group(const System *s, size_t g, int unit) {
    for (int m = s->group_start[g]; m < s->group_start[g + 1]; m++)
        if (s->group_members[m] == unit) return 1;
    return 0;
}

static int get_one(const System *s, int unit, fmi2ValueReference vr, double *value) {
    const Unit *u = &s->units[unit].f;
    return u->get_real(u->component, &vr, 1, value) <= fmi2Warning;
}

/* Set every input of `unit` at the step's start, with slopes towards `end` over h. For a
 * piece of a coupled step, h is the piece's length and the drives start `offset` after the
 * communication point k (master._set_inputs). */
static int set_inputs(const System *s, const Plan *plan, int unit, size_t k, const double *start, const double *end,
                      double h, double offset) {
    const Ports *ports = &plan->ports[unit];
    double values[MAX_PORTS], slopes[MAX_PORTS];
    fmi2Integer orders[MAX_PORTS];
    int any_slope = 0;
    if (!ports->n) return 1;
    for (size_t j = 0; j < ports->n; j++) {
        const size_t i = ports->index[j];
        if (ports->from_link[j]) {
            values[j] = start[i];
            slopes[j] = h > 0 && !s->links[i].hold ? (end[i] - start[i]) / h : 0.0;
        } else {
            const double value = s->drives[i].values[k];
            values[j] = offset != 0.0 ? value + s->drives[i].slopes[k] * offset : value;
            slopes[j] = h > 0 ? s->drives[i].slopes[k] : 0.0;
        }
        any_slope |= slopes[j] != 0.0;
    }
    const Unit *u = &s->units[unit].f;
    if (u->set_real(u->component, ports->vr, ports->n, values) > fmi2Warning) return 0;
    if (h > 0 && any_slope) {
        for (size_t j = 0; j < ports->n; j++) orders[j] = 1;
        if (u->set_input_derivatives(u->component, ports->vr, ports->n, orders, slopes) > fmi2Warning) return 0;
    }
    return 1;
}

static int add_port(Ports *ports, unsigned char from_link, size_t index, fmi2ValueReference vr) {
    if (ports->n >= MAX_PORTS) return 0;
    ports->from_link[ports->n] = from_link;
    ports->index[ports->n] = index;
    ports->vr[ports->n++] = vr;
    return 1;
}

/* Work out the plan; false if a unit has more than MAX_PORTS inputs. */
static int make_plan(const System *s, Plan *plan) {
    for (size_t unit = 0; unit < s->n_units; unit++) {
        Ports *ports = &plan->ports[unit];
        for (size_t d = 0; d < s->n_drives; d++)
            if (s->drives[d].unit == (int)unit && !add_port(ports, 0, d, s->drives[d].vr)) return 0;
        for (size_t l = 0; l < s->n_links; l++)
            if (s->links[l].target == (int)unit && !add_port(ports, 1, l, s->links[l].target_vr)) return 0;
    }
    size_t n = 0;
    for (size_t g = 0; g < s->n_groups; g++) {
        plan->publish_start[g] = n;
        plan->coupled[g] = 0;
        for (size_t l = 0; l < s->n_links; l++) {
            const int source_in = in_group(s, g, s->links[l].source);
            if (source_in) plan->published[n++] = l;
            plan->coupled[g] |= source_in && in_group(s, g, s->links[l].target);
        }
    }
    plan->publish_start[s->n_groups] = n;
    return 1;
}

static int fail(System *s, enum FailKind kind, int unit, double t) {
    s->fail_kind = kind;
    s->fail_unit = unit;
    s->fail_time = t;
    return 0;
}

static int do_step(System *s, int unit, double t, double h) {
    const Unit *u = &s->units[unit].f;
    if (u->do_step(u->component, t, h, fmi2True) > fmi2Warning) return fail(s, FAIL_CALL, unit, t);
    return 1;
}

/* Update the signals of every link whose source is in group g. */
static int publish(System *s, const Plan *plan, size_t g, double *signal, double t) {
    for (size_t j = plan->publish_start[g]; j < plan->publish_start[g + 1]; j++) {
        const size_t l = plan->published[j];
        if (!get_one(s, s->links[l].source, s->links[l].source_vr, &signal[l]))
            return fail(s, FAIL_CALL, s->links[l].source, t);
    }
    return 1;
}

static int is_internal(const System *s, size_t g, size_t l) {
    return in_group(s, g, s->links[l].source) && in_group(s, g, s->links[l].target);
}

/* Make the signals of the links consistent at one instant: all links (group < 0, at the
 * start) or those internal to a group (after a step accepted at a jump: master._settle). */
static int solve_point(System *s, double *signal, double t, long group) {
    for (int it = 0; it < s->max_iterations; it++) {
        double change = 0.0;
        for (size_t l = 0; l < s->n_links; l++) {
            double value;
            const Link *link = &s->links[l];
            if (group >= 0 && !is_internal(s, (size_t)group, l)) continue;
            if (!get_one(s, link->source, link->source_vr, &value)) return fail(s, FAIL_CALL, link->source, t);
            change = fmax(change, fabs(value - signal[l]) / (1.0 + fabs(value)));
            signal[l] = value;
            const Unit *u = &s->units[link->target].f;
            if (u->set_real(u->component, &link->target_vr, 1, &value) > fmi2Warning)
                return fail(s, FAIL_CALL, link->target, t);
        }
        s->last_change = change;
        if (change <= s->tolerance) return 1;
    }
    return fail(s, FAIL_INCONSISTENT_POINT, -1, t);
}

static int is_tear(const System *s, size_t g, size_t l) {
    return s->links[l].source == s->tear_unit[g] && s->links[l].source_vr == s->tear_vr[g];
}

/* coupled.py's EVENT_MARGIN and MAX_PIECES */
#define EVENT_MARGIN 1e-3
#define MAX_PIECES 16

/* The arrays a coupled step works on (per link): at: the group's signals at the piece's
 * start; first, last: every input's value at the piece's start and end. */
typedef struct {
    double *at, *first, *last;
} Piece;

/* Step group g's members in order over the piece [a, b] of [t, t+h] with the tear's end value
 * guessed as x (coupled._torn_step); *out receives the tear's end value as computed. */
static int torn_step(System *s, const Plan *plan, size_t g, size_t k, const double *start, const double *signal,
                     Piece *p, double x, double t, double h, double a, double b, int held, double *out) {
    const double end_time = t + h;
    const double length = (a == t && b == end_time) ? h : b - a;
    for (size_t l = 0; l < s->n_links; l++) {
        if (is_internal(s, g, l)) {
            p->first[l] = p->last[l] = p->at[l];
        } else {
            p->first[l] = a == t ? start[l] : start[l] + (signal[l] - start[l]) * ((a - t) / h);
            p->last[l] = b == end_time ? signal[l] : start[l] + (signal[l] - start[l]) * ((b - t) / h);
        }
        if (is_tear(s, g, l)) p->last[l] = x;
    }
    for (int m = s->group_start[g]; m < s->group_start[g + 1]; m++) {
        const int unit = s->group_members[m];
        if (held)
            for (size_t l = 0; l < s->n_links; l++)
                if (is_internal(s, g, l)) p->first[l] = p->last[l];
        if (!set_inputs(s, plan, unit, k, p->first, p->last, length, a - t)) return fail(s, FAIL_CALL, unit, t);
        if (!do_step(s, unit, a, length)) return 0;
        for (size_t l = 0; l < s->n_links; l++)
            if (s->links[l].source == unit && !is_tear(s, g, l) &&
                !get_one(s, unit, s->links[l].source_vr, &p->last[l]))
                return fail(s, FAIL_CALL, unit, t);
    }
    if (!get_one(s, s->tear_unit[g], s->tear_vr[g], out)) return fail(s, FAIL_CALL, s->tear_unit[g], t);
    return 1;
}

static int save_states(System *s, size_t g, fmi2FMUstate *saved, int restore, double t) {
    for (int m = s->group_start[g]; m < s->group_start[g + 1]; m++) {
        const int unit = s->group_members[m];
        SystemUnit *u = &s->units[unit];
        const fmi2Status status = restore ? u->set_state(u->f.component, saved[unit])
                                          : u->get_state(u->f.component, &saved[unit]);
        if (status > fmi2Warning) return fail(s, FAIL_CALL, unit, t);
    }
    return 1;
}

/* The earliest mode change of a member strictly inside (a, b), from its t_mode
 * (coupled._event_inside): *found is 0 if none. */
static int event_inside(System *s, size_t g, double a, double b, int *found, double *earliest, double t) {
    *found = 0;
    for (int m = s->group_start[g]; m < s->group_start[g + 1]; m++) {
        const int unit = s->group_members[m];
        double t_mode;
        if (s->event_vr[unit] < 0) continue;
        if (!get_one(s, unit, (fmi2ValueReference)s->event_vr[unit], &t_mode)) return fail(s, FAIL_CALL, unit, t);
        if (a < t_mode && t_mode < b && (!*found || t_mode < *earliest)) {
            *found = 1;
            *earliest = t_mode;
        }
    }
    return 1;
}

/* Solve the tear over the piece [a, b] from the states saved at a (coupled._solve_piece):
 * the members end at b as accepted; *inside: whether an event fell strictly inside the
 * accepted piece (not asked for a held one), *estimate its time as the first evaluation had
 * it if it had one inside, else as the accepted one has it. */
static int solve_piece(System *s, const Plan *plan, size_t g, size_t k, const double *start, const double *signal,
                       Piece *p, const TearMemory *memory, double prediction, fmi2FMUstate *saved, double t, double h,
                       double a, double b, int held, TearSolver *solver, int *outcome, int *inside, double *estimate) {
    int first_found = 0;
    double first = 0.0, event = 0.0;
    tear_start(solver, prediction, memory->slope, s->tolerance, s->max_iterations);
    for (;;) {
        const double x = solver->guess;
        double computed;
        s->iterations++;
        if (!torn_step(s, plan, g, k, start, signal, p, x, t, h, a, b, held, &computed)) return 0;
        if (solver->evaluations == 0 && !held && !event_inside(s, g, a, b, &first_found, &first, t)) return 0;
        *outcome = tear_update(solver, x, computed);
        if (*outcome != TEAR_CONTINUE) break;
        if (!save_states(s, g, saved, 1, t)) return 0;
    }
    s->last_change = solver->change;
    if (*outcome == TEAR_EXHAUSTED) return fail(s, FAIL_NOT_CONVERGED, -1, t);
    s->jumps += *outcome == TEAR_JUMP;
    *inside = 0;
    if (!held && !event_inside(s, g, a, b, inside, &event, t)) return 0;
    *estimate = first_found ? first : event;
    return 1;
}

/* A coupled step of a group with a tear (coupled._coupled_step): pieces of the step solved by
 * the root finder of tear.h, split at the events the members report. */
static int tear_step(System *s, const Plan *plan, size_t g, size_t k, double *start, double *signal, Piece *p,
                     TearMemory *memory, fmi2FMUstate *saved, double t, double h) {
    size_t tear_link = 0;
    while (tear_link < s->n_links && !is_tear(s, g, tear_link)) tear_link++;
    if (tear_link == s->n_links) return fail(s, FAIL_CALL, s->tear_unit[g], t); /* the tear feeds no link: not a tear */
    const double end_time = t + h;
    for (size_t l = 0; l < s->n_links; l++) p->at[l] = start[l];
    double a = t, b = end_time, event = 0.0;
    int held = 0, pieces = 0, has_event = 0, outcome = TEAR_CONTINUE;
    double prediction = memory->has_prediction ? memory->prediction : start[tear_link];
    TearSolver solver;
    if (!save_states(s, g, saved, 0, t)) return 0;
    for (;;) {
        int inside;
        double estimate;
        if (!solve_piece(s, plan, g, k, start, signal, p, memory, prediction, saved, t, h, a, b, held, &solver,
                         &outcome, &inside, &estimate))
            return 0;
        pieces++;
        if (inside && pieces < MAX_PIECES) { /* roll back; step to just before the event, or across it held */
            event = estimate;
            has_event = 1;
            if (!save_states(s, g, saved, 1, t)) return 0;
            const double before = event - EVENT_MARGIN * h;
            held = !(before > a);
            b = held ? fmin(event + EVENT_MARGIN * h, end_time) : before;
            prediction = p->at[tear_link];
            continue;
        }
        s->events += held;
        if (outcome == TEAR_JUMP && !solve_point(s, signal, b, (long)g)) return 0;
        if (b == end_time) break;
        for (size_t l = 0; l < s->n_links; l++) /* accept the piece [a, b]; the next starts at b */
            if (is_internal(s, g, l) && !get_one(s, s->links[l].source, s->links[l].source_vr, &p->at[l]))
                return fail(s, FAIL_CALL, s->links[l].source, t);
        held = has_event && !held && b < event;
        a = b;
        b = held ? fmin(event + EVENT_MARGIN * h, end_time) : end_time;
        prediction = p->at[tear_link];
        if (!save_states(s, g, saved, 0, t)) return 0;
    }
    if (!publish(s, plan, g, signal, t)) return 0;
    const double end = signal[tear_link];
    const int smooth = outcome == TEAR_CONVERGED && !has_event;
    memory->prediction = smooth ? 2 * end - start[tear_link] : end;
    memory->slope = outcome == TEAR_JUMP ? 0.0 : solver.slope;
    memory->has_prediction = 1;
    return 1;
}

/* A coupled step of a group without a single-signal tear: fixed-point iteration on all its
 * internal signals (master._iterated_step). */
static int iterated_step(System *s, const Plan *plan, size_t g, size_t k, double *start, double *signal, double *guess,
                         double *previous_end, unsigned char *has_previous, fmi2FMUstate *saved, double t, double h) {
    double ends[MAX_SIGNALS];
    int internal[MAX_SIGNALS];
    for (size_t l = 0; l < s->n_links; l++) {
        internal[l] = is_internal(s, g, l);
        guess[l] = internal[l] ? (has_previous[l] ? previous_end[l] : start[l]) : signal[l];
    }
    for (int m = s->group_start[g]; m < s->group_start[g + 1]; m++) {
        SystemUnit *u = &s->units[s->group_members[m]];
        if (u->get_state(u->f.component, &saved[s->group_members[m]]) > fmi2Warning)
            return fail(s, FAIL_CALL, s->group_members[m], t);
    }
    double change = 0.0;
    for (int it = 0; it < s->max_iterations; it++) {
        s->iterations++;
        for (int m = s->group_start[g]; m < s->group_start[g + 1]; m++)
            if (!set_inputs(s, plan, s->group_members[m], k, start, guess, h, 0.0))
                return fail(s, FAIL_CALL, s->group_members[m], t);
        for (int m = s->group_start[g]; m < s->group_start[g + 1]; m++)
            if (!do_step(s, s->group_members[m], t, h)) return 0;
        change = 0.0;
        for (size_t l = 0; l < s->n_links; l++) {
            if (!internal[l]) continue;
            if (!get_one(s, s->links[l].source, s->links[l].source_vr, &ends[l]))
                return fail(s, FAIL_CALL, s->links[l].source, t);
            change = fmax(change, fabs(ends[l] - guess[l]) / (1.0 + fabs(ends[l])));
        }
        s->last_change = change;
        if (change <= s->tolerance) {
            for (size_t l = 0; l < s->n_links; l++)
                if (internal[l]) {
                    previous_end[l] = 2 * ends[l] - start[l];
                    has_previous[l] = 1;
                }
            return publish(s, plan, g, signal, t);
        }
        for (size_t l = 0; l < s->n_links; l++)
            if (internal[l]) guess[l] = ends[l];
        for (int m = s->group_start[g]; m < s->group_start[g + 1]; m++) {
            SystemUnit *u = &s->units[s->group_members[m]];
            if (u->set_state(u->f.component, saved[s->group_members[m]]) > fmi2Warning)
                return fail(s, FAIL_CALL, s->group_members[m], t);
        }
    }
    return fail(s, FAIL_NOT_CONVERGED, -1, t);
}

static int record_outputs(System *s, size_t row) {
    for (size_t j = 0; j < s->n_outputs; j++)
        if (!get_one(s, s->output_unit[j], s->output_vr[j], &s->outputs[row * s->n_outputs + j]))
            return fail(s, FAIL_CALL, s->output_unit[j], 0.0);
    return 1;
}

static int run_system(System *s, const Plan *plan, double *signal, double *start, double *guess,
                      double *previous_end, unsigned char *has_previous, Piece *piece, TearMemory *memory,
                      fmi2FMUstate *saved) {
    size_t row = 0;
    const double t0 = s->times[0];
    for (size_t unit = 0; unit < s->n_units; unit++)
        if (!set_inputs(s, plan, (int)unit, 0, signal, signal, 0.0, 0.0)) return fail(s, FAIL_CALL, (int)unit, t0);
    if (!solve_point(s, signal, t0, -1)) return 0;
    if (s->record[0] && !record_outputs(s, row++)) return 0;
    for (size_t k = 0; k + 1 < s->n_points; k++) {
        const double t = s->times[k], h = s->times[k + 1] - s->times[k];
        for (size_t l = 0; l < s->n_links; l++) start[l] = signal[l];
        for (size_t g = 0; g < s->n_groups; g++) {
            if (plan->coupled[g] && s->tear_unit[g] >= 0) {
                if (!tear_step(s, plan, g, k, start, signal, piece, &memory[g], saved, t, h)) return 0;
            } else if (plan->coupled[g]) {
                if (!iterated_step(s, plan, g, k, start, signal, guess, previous_end, has_previous, saved, t, h))
                    return 0;
            } else {
                const int unit = s->group_members[s->group_start[g]];
                if (!set_inputs(s, plan, unit, k, start, signal, h, 0.0)) return fail(s, FAIL_CALL, unit, t);
                if (!do_step(s, unit, t, h) || !publish(s, plan, g, signal, t)) return 0;
            }
        }
        if (s->record[k + 1] && !record_outputs(s, row++)) return 0;
    }
    return 1;
}

RUNNER_EXPORT
int pendfmu_run_system(System *s) {
    s->iterations = 0;
    s->jumps = 0;
    s->events = 0;
    s->fail_kind = FAIL_NONE;
    s->fail_unit = -1;
    if (s->n_links > MAX_SIGNALS) return fail(s, FAIL_NO_MEMORY, -1, s->times[0]);
    double *signal = calloc(7 * s->n_links + 1, sizeof(double));
    unsigned char *has_previous = calloc(s->n_links + 1, 1);
    fmi2FMUstate *saved = calloc(s->n_units, sizeof(fmi2FMUstate));
    TearMemory *memory = calloc(s->n_groups + 1, sizeof(TearMemory));
    Plan plan = {calloc(s->n_units + 1, sizeof(Ports)), calloc(s->n_groups * s->n_links + 1, sizeof(size_t)),
                 calloc(s->n_groups + 1, sizeof(size_t)), calloc(s->n_groups + 1, 1)};
    int ok = 0;
    if (!(signal && has_previous && saved && memory && plan.ports && plan.published && plan.publish_start &&
          plan.coupled))
        fail(s, FAIL_NO_MEMORY, -1, s->times[0]);
    else if (!make_plan(s, &plan))
        fail(s, FAIL_TOO_MANY_PORTS, -1, s->times[0]);
    else {
        Piece piece = {signal + 4 * s->n_links, signal + 5 * s->n_links, signal + 6 * s->n_links};
        ok = run_system(s, &plan, signal, signal + s->n_links, signal + 2 * s->n_links, signal + 3 * s->n_links,
                        has_previous, &piece, memory, saved);
    }
    for (size_t unit = 0; saved && unit < s->n_units; unit++)
        if (saved[unit]) s->units[unit].free_state(s->units[unit].f.component, &saved[unit]);
    free(plan.ports);
    free(plan.published);
    free(plan.publish_start);
    free(plan.coupled);
    free(signal);
    free(has_previous);
    free(saved);
    free(memory);
    return ok;
}
