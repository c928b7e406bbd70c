/* Runs one FMI 3.0 FMU binary through the fmi3 Co-Simulation API and prints its trajectory,
 * so that the same source compiled natively (dlopen, the x86_64-linux .so) and with mingw-w64
 * (LoadLibrary, the x86_64-windows .dll, run under wine) can be compared line by line
 * (tests/test_win64_fmi3.py). driver.c does the same for FMI 2.0.
 *
 * Usage: driver3 LIBRARY TOKEN RESOURCE_PATH STOP STEP [option]...
 *   RESOURCE_PATH  FMI 3.0's plain path of the resources folder, with its trailing separator
 *   -p VR=VALUE  set Float64 VR in Initialization Mode (a parameter, or an input's first value)
 *   -s VR=OMEGA  drive Float64 input VR with sin(OMEGA t), held over each step: FMI 3.0 has no
 *                input derivatives in Co-Simulation
 *   -r VR        print Float64 VR     -i VR  print Int32 VR
 *   -e           instantiate with eventModeUsed: a step that returns eventHandlingNeeded is
 *                followed by Event Mode, where the input is set to its value at the step's
 *                end and fmi3UpdateDiscreteStates runs until no further update is needed
 * One line per communication point t_k = k STEP, k = 0 .. round(STOP / STEP): t_k, then the
 * Float64 and the Int32 values in the order given, Float64 with %.17g (round-trip exact),
 * and with -e a last column 1 if the step that ended at t_k asked for Event Mode, else 0.
 * Exit status: 0 done, 1 an fmi3 call failed (the FMU's messages are on stderr), 2 usage. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"

#include "library.h"

#define MAX_EVENT_ITERATIONS 100
#define CALL(call)                                                                \
    if ((call) > fmi3Warning) {                                                   \
        fprintf(stderr, "%s failed at t = %.17g\n", #call, t);                    \
        return 1;                                                                 \
    }

static void log_to_stderr(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env, (void)status;
    fprintf(stderr, "%s: %s\n", category ? category : "?", message ? message : "");
}

int main(int argc, char **argv) {
    if (argc < 6) {
        fprintf(stderr, "usage: driver3 LIBRARY TOKEN RESOURCE_PATH STOP STEP [-p VR=VALUE] [-s VR=OMEGA] [-r VR] "
                        "[-i VR] [-e]\n");
        return 2;
    }
    Library library = open_library(argv[1]);
    if (!library) {
        fprintf(stderr, "cannot load %s\n", argv[1]);
        return 2;
    }
    const double stop = atof(argv[4]), step = atof(argv[5]);
    fmi3ValueReference parameter_vr[MAX_VARIABLES], real_vr[MAX_VARIABLES], integer_vr[MAX_VARIABLES], input_vr = 0;
    double parameter_value[MAX_VARIABLES], omega = 0.0;
    size_t n_parameters = 0, n_reals = 0, n_integers = 0;
    int driven = 0;
    bool event_mode = false;
    for (int k = 6; k < argc; k++) {
        const char *option = argv[k], *value = k + 1 < argc ? argv[k + 1] : NULL;
        if (strcmp(option, "-e") == 0) {
            event_mode = true;
            continue;
        }
        int ok = value != NULL && n_parameters < MAX_VARIABLES && n_reals < MAX_VARIABLES && n_integers < MAX_VARIABLES;
        if (ok && strcmp(option, "-p") == 0) {
            ok = parse_assignment(value, &parameter_vr[n_parameters], &parameter_value[n_parameters]);
            n_parameters++;
        } else if (ok && strcmp(option, "-s") == 0) {
            ok = driven = parse_assignment(value, &input_vr, &omega);
        } else if (ok && strcmp(option, "-r") == 0) {
            real_vr[n_reals++] = (fmi3ValueReference)strtoul(value, NULL, 10);
        } else if (ok && strcmp(option, "-i") == 0) {
            integer_vr[n_integers++] = (fmi3ValueReference)strtoul(value, NULL, 10);
        } else {
            ok = 0;
        }
        if (!ok) {
            fprintf(stderr, "bad option %s %s\n", option, value ? value : "");
            return 2;
        }
        k++;
    }
    LOAD(fmi3InstantiateCoSimulation) LOAD(fmi3EnterInitializationMode) LOAD(fmi3ExitInitializationMode)
    LOAD(fmi3SetFloat64) LOAD(fmi3GetFloat64) LOAD(fmi3GetInt32) LOAD(fmi3DoStep) LOAD(fmi3EnterEventMode)
    LOAD(fmi3UpdateDiscreteStates) LOAD(fmi3EnterStepMode) LOAD(fmi3Terminate) LOAD(fmi3FreeInstance)

    double t = 0.0;
    fmi3Instance c = fmi3InstantiateCoSimulation("driver3", argv[2], argv[3], false, false, event_mode, false, NULL, 0,
                                                 NULL, log_to_stderr, NULL);
    if (!c) {
        fprintf(stderr, "fmi3InstantiateCoSimulation failed (token %s, resources %s)\n", argv[2], argv[3]);
        return 1;
    }
    fmi3Boolean update_needed = event_mode, terminate, nominals_changed, values_changed, next_defined;
    fmi3Boolean event = false, early_return;
    double next_time, last_time, force = 0.0;
    CALL(fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0))
    if (n_parameters) CALL(fmi3SetFloat64(c, parameter_vr, n_parameters, parameter_value, n_parameters))
    CALL(fmi3ExitInitializationMode(c))
    const long n_steps = lround(stop / step);
    double reals[MAX_VARIABLES];
    fmi3Int32 integers[MAX_VARIABLES];
    for (long k = 0;; k++) {
        t = (double)k * step;
        if (update_needed) { /* after initialization, or a step that ended on an event */
            if (k > 0) CALL(fmi3EnterEventMode(c))
            force = sin(omega * t);
            if (driven) CALL(fmi3SetFloat64(c, &input_vr, 1, &force, 1))
            for (int iteration = 0; update_needed; iteration++) {
                if (iteration == MAX_EVENT_ITERATIONS) {
                    fprintf(stderr, "no end of event iterations at t = %.17g\n", t);
                    return 1;
                }
                CALL(fmi3UpdateDiscreteStates(c, &update_needed, &terminate, &nominals_changed, &values_changed,
                                              &next_defined, &next_time))
            }
            CALL(fmi3EnterStepMode(c))
        }
        if (n_reals) CALL(fmi3GetFloat64(c, real_vr, n_reals, reals, n_reals))
        if (n_integers) CALL(fmi3GetInt32(c, integer_vr, n_integers, integers, n_integers))
        printf("%.17g", t);
        for (size_t j = 0; j < n_reals; j++) printf(" %.17g", reals[j]);
        for (size_t j = 0; j < n_integers; j++) printf(" %d", (int)integers[j]);
        if (event_mode) printf(" %d", k > 0 && event ? 1 : 0);
        printf("\n");
        if (k == n_steps) break;
        if (driven) {
            force = sin(omega * t);
            CALL(fmi3SetFloat64(c, &input_vr, 1, &force, 1))
        }
        CALL(fmi3DoStep(c, t, (double)(k + 1) * step - t, true, &event, &terminate, &early_return, &last_time))
        if (terminate || early_return) {
            fprintf(stderr, "fmi3DoStep at t = %.17g: terminate %d, early return %d\n", t, terminate, early_return);
            return 1;
        }
        update_needed = event_mode && event;
    }
    CALL(fmi3Terminate(c))
    fmi3FreeInstance(c);
    return 0;
}
