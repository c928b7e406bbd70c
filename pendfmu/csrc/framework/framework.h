/* The shared framework of pendfmu's component FMUs, FMI 2.0 and FMI 3.0 alike.
 *
 * One binary serves Co-Simulation and Model Exchange. A component provides only its
 * equations (the functions declared at the end of this file) on top of:
 *   - variables.h / variables.c, generated from pendfmu/components.py: value
 *     references, start values, allowed ranges (the single source of truth);
 *   - a facade, fmi2_api.c or fmi3_api.c (an FMU holds one): every function of its FMI
 *     version, the call-order checks, logging through the host's callback;
 *   - instance.c: what both facades do with an instance (get and set with their checks,
 *     initialization, a Co-Simulation step, an event update, time events, FMU states),
 *     so that the two versions cannot compute differently;
 *   - solver.c: the hybrid integrator behind a Co-Simulation step (RK4 on a fixed step that
 *     lands on communication points, mode changes located by root finding).
 *
 * A component is a hybrid system: continuous states x, a discrete mode (an Integer
 * variable, e.g. the stick-slip mode of a friction joint) and event indicators z that
 * are >= 0 while the mode is consistent with the state. An indicator going negative is
 * an event: the mode changes (and states may be reset, e.g. a speed set to exactly 0).
 */
#ifndef PENDFMU_FRAMEWORK_H
#define PENDFMU_FRAMEWORK_H

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "variables.h"

/* Portability: the sources are strict C99 for gcc, clang, mingw-w64 and MSVC. fmi2Functions.h (and fmi3Functions.h)
 * already marks every fmi2 function for export (__declspec(dllexport) on Windows, default
 * visibility under gcc and clang, which -fvisibility=hidden leaves the rest of the library).
 *
 * PRINTF_LIKE(f, a): let the compiler check the format string (argument f) against the
 * arguments from a on, where it can. mingw-w64 in C99 mode formats with its own C99
 * printf (__USE_MINGW_ANSI_STDIO, which knows %zu), so the check must be gnu_printf
 * there: plain `printf` means the Microsoft runtime's dialect on that target. Other
 * compilers (MSVC) get nothing. */
#if defined(__MINGW32__) && __USE_MINGW_ANSI_STDIO
#define PRINTF_LIKE(f, a) __attribute__((format(gnu_printf, f, a)))
#elif defined(__GNUC__) || defined(__clang__)
#define PRINTF_LIKE(f, a) __attribute__((format(printf, f, a)))
#else
#define PRINTF_LIKE(f, a)
#endif

/* Highest order of input derivatives accepted by fmi2SetRealInputDerivatives. */
#define MAX_INPUT_ORDER 3
/* Event iterations allowed at one instant before the model is declared inconsistent. */
#define MAX_EVENT_ITERATIONS 10
/* Internal steps one fmi2DoStep may take: beyond, the parameters make the model too stiff
 * (or solver_step too small) to finish, and the step fails with a message, never hangs. */
#define MAX_INTERNAL_STEPS 10000000.0
/* Width of the time bracket that locates an event, in seconds. */
#define EVENT_TIME_TOLERANCE 1e-12

#define PI 3.14159265358979323846

/* Array lengths that stay legal C for a model without continuous states or event
 * indicators (a sampled controller): the arrays keep one unused slot. Loops and copies
 * run over N_STATES and N_EVENT_INDICATORS. */
#define N_STATES_ALLOC (N_STATES > 0 ? N_STATES : 1)
#define N_EVENT_INDICATORS_ALLOC (N_EVENT_INDICATORS > 0 ? N_EVENT_INDICATORS : 1)

/* Two time events closer than this (relative to max(1, |t|)) are the same instant: a
 * sample time and a communication point that differ by rounding coincide. */
#define TIME_EVENT_TOLERANCE 1e-9

/* Slots of DynamicState.memo */
#define MEMO_SIZE 12
/* Slots of DynamicState.derived */
#define DERIVED_SIZE 8

typedef enum {
    CAUSALITY_PARAMETER,
    CAUSALITY_INPUT,
    CAUSALITY_OUTPUT,
    CAUSALITY_LOCAL
} Causality;

typedef struct {
    const char *name;
    Causality causality;
    double start;
    bool has_low, has_high, low_open;
    double low, high;
} RealInfo;

typedef struct {
    const char *name;
    Causality causality;
    int start;
} DiscreteInfo;

/* Defined in the generated variables.c */
extern const RealInfo REAL_INFO[N_REAL];
extern const DiscreteInfo INTEGER_INFO[N_INTEGER];
extern const DiscreteInfo BOOLEAN_INFO[N_BOOLEAN];
extern const unsigned STATE_VR[N_STATES_ALLOC];
extern const unsigned INPUT_VR[N_INPUTS];

/* The states of the FMI call sequence, as bits so that each function can name the set of
 * states it may be called in. FMI 3.0's Step Mode is FMU_STEP_COMPLETE, and its Event Mode
 * is FMU_EVENT_MODE in Co-Simulation too (when the importer uses it). */
typedef enum {
    FMU_INSTANTIATED = 1 << 0,
    FMU_INITIALIZATION = 1 << 1,
    FMU_STEP_COMPLETE = 1 << 2,   /* Co-Simulation, between steps */
    FMU_EVENT_MODE = 1 << 3,      /* Model Exchange; FMI 3.0 Co-Simulation with event mode */
    FMU_CONTINUOUS_MODE = 1 << 4, /* Model Exchange */
    FMU_TERMINATED = 1 << 5,
    FMU_ERROR = 1 << 6
} FmuPhase;

/* How current the output and local variables are. */
typedef enum {
    OUTPUTS_STALE = 0, /* recompute, making the mode consistent with the inputs first */
    OUTPUTS_STEPPED,   /* a Co-Simulation step just ended: the mode is consistent and the states'
                          variables are current; the other outputs are computed when first read */
    OUTPUTS_CURRENT
} OutputsStatus;

/* Everything that changes while an instance runs: exactly what an FMU state holds. */
typedef struct {
    double time;
    double r[N_REAL];
    int i[N_INTEGER];
    bool b[N_BOOLEAN];
    double x[N_STATES_ALLOC];
    /* Co-Simulation input interpolation: u(t) = u_base + sum_k taylor[k-1] (t-uder_time)^k,
     * taylor[k-1] being the k-th derivative over k! */
    double u_base[N_REAL];
    double taylor[N_REAL][MAX_INPUT_ORDER];
    int uder_order[N_REAL]; /* highest nonzero derivative order of each input (0: held) */
    double uder_time;
    bool uder_set;
    FmuPhase phase;
    OutputsStatus outputs;
    long event_count;
    /* The RK4 step limit, min(solver_step, model_max_step()): fixed with the parameters,
     * so computed once at initialization. */
    double h_rk4;
    /* A model's memos of expensive pure functions (the sines and cosines of trig_memo.h,
     * exponentials of the last step size). They live in the state, so a restored FMU
     * state repeats a run to the bit. Each model lays out its own slots. */
    double memo[MEMO_SIZE];
    /* Constants a model derives from its parameters in model_initial_states (parameters are
     * fixed from then on), so that the equations evaluated at every RK4 stage stay short. */
    double derived[DERIVED_SIZE];
#ifdef MODEL_STORE_SIZE
    /* A sampled model's discrete state (sample histories, delay line, integrator), laid out
     * by the model; only components whose table asks for it have one. */
    double store[MODEL_STORE_SIZE];
#endif
} DynamicState;

/* The version-neutral part of an instance. A facade allocates its own struct with this as
 * its first member and the host's callbacks after it (their types differ between FMI 2.0
 * and 3.0), so an instance pointer is both. */
typedef struct {
    DynamicState s;
    double start[N_REAL]; /* start values: the table's, or a parameterized FMU's (start.c) */
    bool co_simulation;   /* else Model Exchange */
    bool event_mode_used; /* FMI 3.0 Co-Simulation: the importer enters Event Mode for time events */
    char *name;
    bool logging_on;
    bool log_events;
    bool time_events; /* the model has time events (model_next_time_event finite after initialization) */
} Instance;

/* Logging through the host's logger callback (never crashes on a NULL logger); each facade
 * implements these for its version's callback. */
void log_error(const Instance *inst, const char *format, ...) PRINTF_LIKE(2, 3);
void log_event(const Instance *inst, const char *format, ...) PRINTF_LIKE(2, 3);
/* The facade's name of a phase, for messages ("step complete" in FMI 2.0, "Step Mode" in 3.0). */
const char *phase_name(FmuPhase phase);

/* ---- The version-neutral work of the facades (instance.c) ----
 * Functions returning bool have, on false, logged why (the message starts with `function`,
 * the facade's function name) and put the instance into FMU_ERROR; the facade then
 * returns its version's Error status. Value references are those of variables.h. */

/* Fail with a logged message: the instance enters FMU_ERROR. Returns false. */
bool instance_fail(Instance *inst, const char *format, ...) PRINTF_LIKE(2, 3);
/* Back to the start values, phase FMU_INSTANTIATED (after instantiation and reset). */
void instance_reset(Instance *inst);
/* SetDebugLogging: the categories the model description declares (logEvents, logStatusError;
 * none named: all of them); an unknown one is refused. */
bool instance_set_debug_logging(Instance *inst, const char *function, bool on, size_t n,
                                const char *const categories[]);
/* The start of the simulation (SetupExperiment in FMI 2.0, EnterInitializationMode in 3.0):
 * a finite start, and a stop time, if given, not before it. */
bool instance_set_start(Instance *inst, const char *function, double start, bool stop_defined, double stop);
/* Leave initialization mode: check the parameters, initialize the solver and the outputs;
 * the phase stays the caller's to set. */
bool instance_exit_initialization(Instance *inst, const char *function);
/* Getters: update the outputs if needed, then copy. */
bool instance_get_reals(Instance *inst, const char *function, const unsigned vr[], size_t nvr, double value[]);
bool instance_get_integers(Instance *inst, const char *function, const unsigned vr[], size_t nvr, int value[]);
/* Setters: check every value (causality against the phase, finite, physical range) before
 * changing any, so a refused call leaves the values as they were. */
bool instance_set_reals(Instance *inst, const char *function, const unsigned vr[], size_t nvr, const double value[]);
bool instance_set_integers(Instance *inst, const char *function, const unsigned vr[], size_t nvr, const int value[]);
/* Booleans (an int in FMI 2.0, a bool in 3.0): check the references (and, to set, that the
 * variables may be set now; to get, update the outputs); the facade then copies
 * inst->s.b[vr - VR_BOOLEAN_BASE] (setting marks the outputs stale already). */
bool instance_boolean_access(Instance *inst, const char *function, const unsigned vr[], size_t nvr, bool set);
/* A Co-Simulation step from `t` of size `h`, time events included. */
bool instance_do_step(Instance *inst, const char *function, double t, double h);
/* Whether a time event falls on the current time and has not been taken yet. */
bool instance_time_event_due(const Instance *inst);
/* An event update at the current time (Event Mode): the mode made consistent, the time
 * events due taken. Reports whether the states changed and the next time event (INFINITY:
 * none). */
bool instance_update_discrete_states(Instance *inst, const char *function, bool *states_changed,
                                     double *next_event_time);
/* Whether an event indicator is negative now: an event was stepped over (Model Exchange). */
bool instance_event_indicator_crossed(const Instance *inst);
/* Model Exchange: set states, time; get derivatives, indicators. */
bool instance_set_time(Instance *inst, const char *function, double time);
bool instance_set_states(Instance *inst, const char *function, const double x[], size_t nx);
bool instance_check_count(Instance *inst, const char *function, const void *array, size_t n, int expected,
                          const char *what);
/* FMU states: a serialized state is a fixed-size record of the magic, the build's GUID
 * (instantiation token in FMI 3.0) and the DynamicState, checked when read back. */
size_t instance_serialized_size(void);
bool instance_serialize(Instance *inst, const char *function, const DynamicState *state, unsigned char *bytes,
                        size_t size);
bool instance_deserialize(Instance *inst, const char *function, const unsigned char *bytes, size_t size,
                          DynamicState *state);

/* Start values of a parameterized FMU (start.c): accept `guid` if the FMU's resources
 * carry a start-value file for it, and apply its values to inst->start. */
bool start_values_accept(Instance *inst, const char *guid, const char *resource_location);
/* The same for FMI 3.0, whose resourcePath is a local path, not a URI; `token` is the
 * instantiationToken. */
bool start_values_accept_path(Instance *inst, const char *token, const char *resource_path);

/* Solver services (solver.c) */
void solver_inputs_at(Instance *inst, double t);
bool solver_event_iteration(Instance *inst, double t);
bool solver_do_step(Instance *inst, double t_end);
bool solver_initialize(Instance *inst);

/* Short names for variables in the model files: R(T_i) is the value of Real T_i. */
#define R(name) (inst->s.r[VR_##name])
#define MODE (inst->s.i[VR_mode - VR_INTEGER_BASE])
#define FLAG(name) (inst->s.b[VR_##name - VR_BOOLEAN_BASE])

/* ---- What each component implements (pendfmu/csrc/<Name>/model.c) ---- */

/* Cross-parameter checks beyond the ranges of the variable table. On failure writes a
 * message naming the parameters into `why` and returns false. */
bool model_check_parameters(const Instance *inst, char *why, size_t size);

/* Set the continuous states from the parameters (x0, v0, ...), and derive the constants of
 * DynamicState.derived. Called once, at initialization. */
void model_initial_states(Instance *inst);

/* A step that RK4 must not exceed for accuracy and stability (INFINITY when the model needs
 * none beyond solver_step). Depends on parameters only: evaluated once, at initialization. */
double model_max_step(const Instance *inst);

/* The exact solution over [t, t+h] for the current mode, where the model has one (inputs
 * are evaluated at t; whether one is held or ramped, and its slope, come from
 * input_is_linear()); returns false to let the solver integrate with RK4. An exact step is
 * taken over the whole remaining communication interval (solver_step bounds RK4 only). */
bool model_exact_step(Instance *inst, double t, const double *x, double h, double *x_out);

/* The first-order Taylor coefficient of Real input vr over the current step, and whether
 * the input is at most linear there (no second or third derivative). */
bool input_is_linear(const Instance *inst, unsigned vr, double *slope);

/* dx/dt at time t for the current mode; inputs are already evaluated at t. */
void model_derivatives(const Instance *inst, double t, const double *x, double *dx);

/* Event indicators: >= 0 while the mode is consistent with x and the inputs. */
void model_event_indicators(const Instance *inst, double t, const double *x, double *z);

/* At an event: choose the mode consistent with x and the inputs, resetting states where
 * the mode demands it (a joint that sticks has speed exactly 0). Returns true when the
 * mode or a state changed. */
bool model_update_mode(Instance *inst, double t, double *x);

/* Fill outputs and local variables (r, i, b) from t, x, inputs and the mode. */
void model_outputs(Instance *inst, double t, const double *x);

/* Time events: instants a model fixes in advance (the samples of a discrete controller).
 * The time of the next time event not yet taken, INFINITY when there is none (a purely
 * continuous model). */
double model_next_time_event(const Instance *inst);

/* The time event at t = model_next_time_event(), with the inputs evaluated at t. With
 * `commit`, the event is taken: the model updates its discrete state and outputs, and the
 * next time event moves on. Without, the model only sets the outputs the event would give
 * with the current inputs and changes nothing else: a Co-Simulation master may still set
 * the inputs of a communication point on which an event falls (see fmi2DoStep). */
void model_time_event(Instance *inst, double t, bool commit);

/* How far [s] a time event may lie from a Co-Simulation communication point and still be
 * taken at that point, with the inputs set there: a sampled model whose master's points
 * jitter around its samples (logged time stamps) then takes each sample at its point, not
 * in the step before with the previous inputs. 0: the framework's TIME_EVENT_TOLERANCE alone.
 * Model Exchange takes time events where the importer stops for them, without a window. */
double model_time_event_window(const Instance *inst);

/* The time-event hooks of a continuous model, which has none: one line in its model.c. */
#define NO_TIME_EVENTS                                                                          \
    double model_next_time_event(const Instance *inst) { (void)inst; return INFINITY; }        \
    void model_time_event(Instance *inst, double t, bool commit) { (void)inst, (void)t, (void)commit; } \
    double model_time_event_window(const Instance *inst) { (void)inst; return 0.0; }

/* The continuous hooks of a purely sampled model (a controller), which has no continuous
 * states, event indicators or modes between samples: one line in its model.c. Its outputs
 * are set at the samples and held in between. */
#define NO_CONTINUOUS_DYNAMICS                                                                  \
    double model_max_step(const Instance *inst) { (void)inst; return INFINITY; }               \
    bool model_exact_step(Instance *inst, double t, const double *x, double h, double *x_out) { \
        (void)inst, (void)t, (void)x, (void)h, (void)x_out;                                     \
        return true;                                                                            \
    }                                                                                           \
    void model_derivatives(const Instance *inst, double t, const double *x, double *dx) {      \
        (void)inst, (void)t, (void)x, (void)dx;                                                 \
    }                                                                                           \
    void model_event_indicators(const Instance *inst, double t, const double *x, double *z) {  \
        (void)inst, (void)t, (void)x, (void)z;                                                  \
    }                                                                                           \
    bool model_update_mode(Instance *inst, double t, double *x) { (void)inst, (void)t, (void)x; return false; } \
    void model_outputs(Instance *inst, double t, const double *x) { (void)inst, (void)t, (void)x; }

/* The time-event hooks of a model sampled at t_0 + k T_s (the start time t_0 in store slot T0,
 * the samples taken so far, k, in slot K): a communication point within JITTER T_s of a sample
 * is that sample's instant (logged time stamps jitter: EMPS's by 3e-8 s around whole
 * milliseconds, and a sample taken in the step before would read the previous point's inputs). */
/* Whether a sampled model's T_s keeps its samples distinct instants: far apart compared with the
 * tolerance within which the framework takes a sample time and a communication point as one
 * (else `why` says so, naming `model`). The one home of that rule for every sampled model. */
static inline bool sample_time_resolved(const Instance *inst, const char *model, double T_s, char *why,
                                        size_t size) {
    const double resolution = 1e3 * TIME_EVENT_TOLERANCE * fmax(1.0, fabs(inst->s.time));
    if (T_s >= resolution) return true;
    snprintf(why, size, "%s: the sample time T_s = %g s is below %g s (samples closer than that cannot be told "
             "apart from rounding at t = %g s)", model, T_s, resolution, inst->s.time);
    return false;
}

#define SAMPLED_EVERY_T_S(T0, K, JITTER)                                                        \
    double model_next_time_event(const Instance *inst) {                                        \
        return inst->s.store[T0] + inst->s.store[K] * R(T_s);                                   \
    }                                                                                           \
    double model_time_event_window(const Instance *inst) { return (JITTER) * R(T_s); }

#endif
