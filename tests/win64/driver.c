/* Runs one FMU binary through the fmi2 API and prints its trajectory, so that the same
 * source compiled natively (dlopen, the linux64 .so) and with mingw-w64 (LoadLibrary, the
 * win64 .dll, run under wine) can be compared line by line (tests/test_win64.py).
 *
 * Usage: driver LIBRARY GUID RESOURCE_URI STOP STEP [option]...
 *   -p VR=VALUE  set Real parameter VR in initialization mode
 *   -s VR=OMEGA  drive Real input VR with sin(OMEGA t), its 1st to 3rd derivatives given at
 *                every communication point (the paper's Fig. 3 force)
 *   -r VR        print Real output VR     -i VR  print Integer output VR
 * One line per communication point t_k = k STEP, k = 0 .. round(STOP / STEP): t_k, then
 * the Real and the Integer outputs in the order given, Reals with %.17g (round-trip exact).
 * Exit status: 0 done, 1 an fmi2 call failed (the FMU's messages are on stderr), 2 usage. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#include "library.h"

#define CALL(call)                                                                \
    if ((call) > fmi2Warning) {                                                   \
        fprintf(stderr, "%s failed at t = %.17g\n", #call, t);                    \
        return 1;                                                                 \
    }

static void log_to_stderr(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                          fmi2String message, ...) {
    (void)env, (void)status;
    fprintf(stderr, "[%s] %s: %s\n", name ? name : "?", category ? category : "?", message ? message : "");
}

int main(int argc, char **argv) {
    if (argc < 6) {
        fprintf(stderr, "usage: driver LIBRARY GUID RESOURCE_URI STOP STEP [-p VR=VALUE] [-s VR=OMEGA] [-r VR] [-i VR]\n");
        return 2;
    }
    Library library = open_library(argv[1]);
    if (!library) {
        fprintf(stderr, "cannot load %s\n", argv[1]);
        return 2;
    }
    const double stop = atof(argv[4]), step = atof(argv[5]);
    fmi2ValueReference parameter_vr[MAX_VARIABLES], real_vr[MAX_VARIABLES], integer_vr[MAX_VARIABLES], input_vr = 0;
    double parameter_value[MAX_VARIABLES], omega = 0.0;
    size_t n_parameters = 0, n_reals = 0, n_integers = 0;
    int driven = 0;
    for (int k = 6; k < argc; k++) {
        const char *option = argv[k], *value = k + 1 < argc ? argv[k + 1] : NULL;
        int ok = value != NULL && n_parameters < MAX_VARIABLES && n_reals < MAX_VARIABLES && n_integers < MAX_VARIABLES;
        if (ok && strcmp(option, "-p") == 0) {
            ok = parse_assignment(value, &parameter_vr[n_parameters], &parameter_value[n_parameters]);
            n_parameters++;
        } else if (ok && strcmp(option, "-s") == 0) {
            ok = driven = parse_assignment(value, &input_vr, &omega);
        } else if (ok && strcmp(option, "-r") == 0) {
            real_vr[n_reals++] = (fmi2ValueReference)strtoul(value, NULL, 10);
        } else if (ok && strcmp(option, "-i") == 0) {
            integer_vr[n_integers++] = (fmi2ValueReference)strtoul(value, NULL, 10);
        } else {
            ok = 0;
        }
        if (!ok) {
            fprintf(stderr, "bad option %s %s\n", option, value ? value : "");
            return 2;
        }
        k++;
    }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode) LOAD(fmi2ExitInitializationMode)
    LOAD(fmi2SetReal) LOAD(fmi2SetRealInputDerivatives) LOAD(fmi2DoStep) LOAD(fmi2GetReal) LOAD(fmi2GetInteger)
    LOAD(fmi2Terminate) LOAD(fmi2FreeInstance)

    fmi2CallbackFunctions callbacks = {log_to_stderr, calloc, free, NULL, NULL};
    double t = 0.0;
    fmi2Component c = fmi2Instantiate("driver", fmi2CoSimulation, argv[2], argv[3], &callbacks, fmi2False, fmi2False);
    if (!c) {
        fprintf(stderr, "fmi2Instantiate failed (GUID %s, resources %s)\n", argv[2], argv[3]);
        return 1;
    }
    CALL(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0))
    CALL(fmi2EnterInitializationMode(c))
    if (n_parameters) CALL(fmi2SetReal(c, parameter_vr, n_parameters, parameter_value))
    CALL(fmi2ExitInitializationMode(c))

    const long n_steps = lround(stop / step);
    double reals[MAX_VARIABLES];
    fmi2Integer integers[MAX_VARIABLES];
    for (long k = 0;; k++) {
        t = (double)k * step;
        if (n_reals) CALL(fmi2GetReal(c, real_vr, n_reals, reals))
        if (n_integers) CALL(fmi2GetInteger(c, integer_vr, n_integers, integers))
        printf("%.17g", t);
        for (size_t j = 0; j < n_reals; j++) printf(" %.17g", reals[j]);
        for (size_t j = 0; j < n_integers; j++) printf(" %d", (int)integers[j]);
        printf("\n");
        if (k == n_steps) break;
        if (driven) {
            const double force = sin(omega * t);
            const fmi2ValueReference vrs[3] = {input_vr, input_vr, input_vr};
            const fmi2Integer orders[3] = {1, 2, 3};
            const double derivatives[3] = {omega * cos(omega * t), -omega * omega * sin(omega * t),
                                           -omega * omega * omega * cos(omega * t)};
            CALL(fmi2SetReal(c, &input_vr, 1, &force))
            CALL(fmi2SetRealInputDerivatives(c, vrs, 3, orders, derivatives))
        }
        CALL(fmi2DoStep(c, t, (double)(k + 1) * step - t, fmi2True))
    }
    CALL(fmi2Terminate(c))
    fmi2FreeInstance(c);
    return 0;
}
