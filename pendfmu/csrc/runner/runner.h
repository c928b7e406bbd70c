/* The native loop's interface: the structures it is called with, how it fails, and its limits.
 *
 * pendfmu/simulator/native.py mirrors this file with ctypes (Unit, SystemUnit, Link, Drive,
 * System, Failure, MAX_PORTS) and tests/test_native_interface.py checks that both say the same:
 * every field at the same offset, every failure kind and limit with the same value.
 * scripts/bench_limit.c includes it for Unit.
 */
#ifndef PENDFMU_RUNNER_H
#define PENDFMU_RUNNER_H

#include <stddef.h>

#include "fmi2Functions.h"

/* The loop's two entry points are exported like the fmi2 functions: fmi2Functions.h's
 * FMI2_Export is default visibility under gcc and clang (the library is built with
 * -fvisibility=hidden) and __declspec(dllexport) on Windows. */
#define RUNNER_EXPORT FMI2_Export

/* Inputs one unit may have: the loop keeps them in arrays of this size. */
#define MAX_PORTS 64

/* System.fail_kind: what stopped a run (native.Failure). */
enum FailKind {
    FAIL_NONE = 0,
    FAIL_CALL = 1,               /* an fmi2 call failed (the FMU has logged why) */
    FAIL_NOT_CONVERGED = 2,      /* a coupled step did not converge */
    FAIL_NO_MEMORY = 3,          /* out of memory, or more links than MAX_SIGNALS (runner.c) */
    FAIL_INCONSISTENT_POINT = 4, /* the connected signals could not be made consistent at one
                                    instant (the start, or a step's end accepted at a jump) */
    FAIL_TOO_MANY_PORTS = 5      /* a unit has more than MAX_PORTS inputs */
};

/* One FMU instance: its component and the fmi2 functions of the library that loaded it. */
typedef struct {
    fmi2Component component;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2SetRealInputDerivativesTYPE *set_input_derivatives;
} Unit;

/* A unit of a system, which also rolls back (coupled steps). */
typedef struct {
    Unit f;
    fmi2GetFMUstateTYPE *get_state;
    fmi2SetFMUstateTYPE *set_state;
    fmi2FreeFMUstateTYPE *free_state;
} SystemUnit;

typedef struct {
    int source, target;
    fmi2ValueReference source_vr, target_vr;
    int hold; /* 1: a discrete output, held over a step (master.py: held) */
} Link;

typedef struct {
    int unit;
    fmi2ValueReference vr;
    const double *values; /* at each communication point */
    const double *slopes; /* over the step that starts there */
} Drive;

typedef struct {
    size_t n_units;
    SystemUnit *units;
    size_t n_links;
    const Link *links;
    size_t n_drives;
    const Drive *drives;
    size_t n_groups;
    const int *group_start; /* n_groups + 1 offsets into group_members */
    const int *group_members;
    const int *tear_unit; /* per group: the unit whose output tears its loop, or -1 (none) */
    const fmi2ValueReference *tear_vr;
    const long *event_vr; /* per unit: value reference of its t_mode (time of its last mode change), or -1 */
    double tolerance;
    int max_iterations;
    size_t n_points;
    const double *times;
    const unsigned char *record; /* 1 where outputs are recorded */
    size_t n_outputs;
    const int *output_unit;
    const fmi2ValueReference *output_vr;
    double *outputs;
    /* results */
    long iterations;
    long jumps;  /* pieces of coupled steps whose loop map jumped (tear.h) */
    long events; /* events inside coupled steps crossed by held pieces */
    double fail_time;
    int fail_kind; /* enum FailKind */
    int fail_unit;
    double last_change;
} System;

#endif
