/* The shared FMI 2.0 framework of pendfmu's component FMUs.
 *
 * One binary serves Co-Simulation and Model Exchange. A component provides only its
 * equations (the functions declared at the end of this file) on top of:
 *   - variables.h / variables.c, generated from pendfmu/components.py: value
 *     references, start values, allowed ranges (the single source of truth);
 *   - fmi2_api.c: every fmi2 function, the call-order state machine, checks, logging;
 *   - solver.c: the hybrid integrator behind fmi2DoStep (RK4 on a fixed step that lands
 *     on communication points, mode changes located by root finding).
 *
 * A component is a hybrid system: continuous states x, a discrete mode (an Integer
 * variable, e.g. the stick-slip mode of a friction joint) and event indicators z that
 * are >= 0 while the mode is consistent with the state. An indicator going negative is
 * an event: the mode changes (and states may be reset, e.g. a speed set to exactly 0).
 */
#ifndef PENDFMU_FRAMEWORK_H
#define PENDFMU_FRAMEWORK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "fmi2Functions.h"
#include "variables.h"

/* Portability: the sources are strict C99 for gcc, clang, mingw-w64 and MSVC. fmi2Functions.h
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

/* The states of the FMI 2.0 call sequence, as bits so that each function can name the
 * set of states it may be called in. */
typedef enum {
    FMU_INSTANTIATED = 1 << 0,
    FMU_INITIALIZATION = 1 << 1,
    FMU_STEP_COMPLETE = 1 << 2,   /* Co-Simulation, between steps */
    FMU_EVENT_MODE = 1 << 3,      /* Model Exchange */
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

typedef struct {
    DynamicState s;
    double start[N_REAL]; /* start values: the table's, or a parameterized FMU's (start.c) */
    fmi2Type type;
    char *name;
    fmi2CallbackFunctions cb;
    bool logging_on;
    bool log_events;
    bool time_events; /* the model has time events (model_next_time_event finite after initialization) */
} Instance;

/* Logging through the host's logger callback (never crashes on a NULL logger). */
void log_error(const Instance *inst, const char *format, ...) PRINTF_LIKE(2, 3);
void log_event(const Instance *inst, const char *format, ...) PRINTF_LIKE(2, 3);

/* Start values of a parameterized FMU (start.c): accept `guid` if the FMU's resources
 * carry a start-value file for it, and apply its values to inst->start. */
bool start_values_accept(Instance *inst, const char *guid, const char *resource_location);

/* Solver services (solver.c) */
void solver_inputs_at(Instance *inst, double t);
bool solver_event_iteration(Instance *inst, double t);
bool solver_do_step(Instance *inst, double t_end);
bool solver_initialize(Instance *inst);

/* Short names for variables in the model files: R(T_i) is the value of Real T_i. */
#define R(name) (inst->s.r[VR_##name])
#define MODE (inst->s.i[VR_mode - VR_INTEGER_BASE])
#define FLAG(name) (inst->s.b[VR_##name - VR_BOOLEAN_BASE])

/* ---- What each component implements (fmus/<Name>/model.c) ---- */

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

#endif
