/* The small FMI 2.0 layer shared by the foreign test FMUs (tests/foreign/).

   These FMUs stand for FMUs that pendfmu did not make (a Simulink or OpenModelica export):
   they are written against the FMI 2.0 headers only and share nothing with pendfmu's own
   framework in pendfmu/csrc/framework/. What they share among themselves is kept to this one
   layer: the instance, the call-order phases, value access by value reference with
   checks, logging, and FMU state copies. Each model file (ForeignCart.c, NoStateCart.c,
   MEOnly.c, Colliding.c) defines one `Model` with its variable table and equations.

   Every variable lives in one array indexed by its value reference (Real and Integer
   separately), so an FMU state is a plain copy of `Data`. */

#ifndef FOREIGN_H
#define FOREIGN_H

#include <stddef.h>

#include "fmi2Functions.h"

#define MAX_REALS 32     /* Real value references must be below this */
#define MAX_INTEGERS 4   /* Integer value references must be below this */
#define MAX_STATES 4     /* continuous states of a Model Exchange model */

typedef enum { PARAMETER, INPUT, OUTPUT, LOCAL } Causality;

/* A Real variable. Parameters are checked against [low, high] (low excluded when
   low_open) when they are set; every Real must be finite. */
typedef struct {
    fmi2ValueReference vr;
    const char *name;
    Causality causality;
    double start;
    double low, high;
    int low_open;
    const char *meaning;  /* said in the error message of an out-of-range value */
} RealVariable;

/* An Integer variable: only read-only locals here (e.g. the friction mode). */
typedef struct {
    fmi2ValueReference vr;
    const char *name;
    int start;
} IntegerVariable;

/* Everything an FMU state must hold: the values by value reference and the time. */
typedef struct {
    double time;
    double r[MAX_REALS];
    int i[MAX_INTEGERS];
} Data;

typedef enum { INSTANTIATED, INITIALIZATION, STEPPING, EVENT_MODE, CONTINUOUS_MODE, TERMINATED, FAILED } Phase;

typedef struct Instance Instance;

typedef struct {
    const char *name;          /* the modelIdentifier */
    const char *guid;          /* must equal modelDescription.xml's guid */
    const RealVariable *reals;
    size_t n_reals;
    const IntegerVariable *integers;
    size_t n_integers;
    int can_get_set_state;     /* canGetAndSetFMUstate and canSerializeFMUstate */
    int can_reset;             /* 0: fmi2Reset fails, the host must instantiate again */
    /* Computes states and outputs from parameters and inputs (initialization mode and
       fmi2ExitInitializationMode); may refuse a combination of parameters. */
    fmi2Status (*initialize)(Instance *);
    /* Co-Simulation: advance d.time by h (> 0) with the inputs held. NULL for ME only. */
    fmi2Status (*do_step)(Instance *, double h);
    /* Computes what depends on the inputs and states at this instant (derivatives,
       outputs with direct feedthrough) into d.r; called before values are read. May be NULL. */
    void (*update)(Instance *);
    /* Model Exchange: the value references of the states and of their derivatives
       (computed by `update`). n_states 0 for CS only. */
    size_t n_states;
    const fmi2ValueReference *state_vrs;
    const fmi2ValueReference *derivative_vrs;
} Model;

struct Instance {
    Data d;
    Phase phase;
    const Model *model;
    char *name;
    fmi2CallbackFunctions functions;
    int debug_logging;
};

extern const Model MODEL;  /* defined by the model file */

/* Logs an error (always, whatever the debug logging flag says), returns fmi2Error. */
fmi2Status fail(Instance *c, const char *format, ...) __attribute__((format(printf, 2, 3)));

#endif
