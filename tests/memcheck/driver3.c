/* Exercises one FMI 3.0 FMU binary through its fmi3 functions, for valgrind memcheck
 * (tests/test_memcheck.py), as driver.c does for FMI 2.0: Co-Simulation with event mode and
 * FMU state save/restore/serialize, a Model Exchange sequence, the misuse cases that must
 * return fmi3Error, a wrong instantiationToken, and instantiate/free cycles.
 * Usage: driver3 LIBRARY TOKEN RESOURCE_PATH INPUT_VR PARAMETER_VR N_STATES N_INDICATORS */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"

#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(library, #name); if (!name) { fprintf(stderr, "no %s\n", #name); return 2; }
#define EXPECT(call, status) do { if ((call) != (status)) { fprintf(stderr, "line %d: %s did not return %d\n", __LINE__, #call, status); return 1; } } while (0)

static int errors_logged = 0;

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env, (void)category, (void)message;
    if (status == fmi3Error) errors_logged++;
}

int main(int argc, char **argv) {
    if (argc != 8) return 2;
    void *library = dlopen(argv[1], RTLD_NOW);
    if (!library) { fprintf(stderr, "%s\n", dlerror()); return 2; }
    const char *token = argv[2], *resources = argv[3];
    fmi3ValueReference input = (fmi3ValueReference)atoi(argv[4]), parameter = (fmi3ValueReference)atoi(argv[5]);
    size_t n_states = (size_t)atoi(argv[6]), n_indicators = (size_t)atoi(argv[7]);
    LOAD(fmi3InstantiateCoSimulation) LOAD(fmi3InstantiateModelExchange) LOAD(fmi3FreeInstance)
    LOAD(fmi3EnterInitializationMode) LOAD(fmi3ExitInitializationMode) LOAD(fmi3DoStep) LOAD(fmi3SetFloat64)
    LOAD(fmi3GetFloat64) LOAD(fmi3Reset) LOAD(fmi3GetFMUState) LOAD(fmi3SetFMUState) LOAD(fmi3FreeFMUState)
    LOAD(fmi3SerializedFMUStateSize) LOAD(fmi3SerializeFMUState) LOAD(fmi3DeserializeFMUState) LOAD(fmi3Terminate)
    LOAD(fmi3GetContinuousStateDerivatives) LOAD(fmi3GetEventIndicators) LOAD(fmi3UpdateDiscreteStates)
    LOAD(fmi3EnterContinuousTimeMode) LOAD(fmi3EnterStepMode) LOAD(fmi3SetContinuousStates)
    LOAD(fmi3GetContinuousStates) LOAD(fmi3CompletedIntegratorStep) LOAD(fmi3SetTime) LOAD(fmi3EnterEventMode)
    LOAD(fmi3SetDebugLogging)
    fmi3Boolean need, terminate, nominals, values, defined, event, early;
    double next_time, last_time;

    /* Co-Simulation with event mode, state save, restore and serialization */
    fmi3Instance c = fmi3InstantiateCoSimulation("cs", token, resources, false, true, true, false, NULL, 0, NULL,
                                                 logger, NULL);
    if (!c) return 1;
    EXPECT(fmi3SetDebugLogging(c, true, 0, NULL), fmi3OK);
    EXPECT(fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0), fmi3OK);
    EXPECT(fmi3ExitInitializationMode(c), fmi3OK);
    EXPECT(fmi3UpdateDiscreteStates(c, &need, &terminate, &nominals, &values, &defined, &next_time), fmi3OK);
    EXPECT(fmi3EnterStepMode(c), fmi3OK);
    double t = 0.0, value = 1.5, out[4];
    fmi3FMUState state = NULL, copy = NULL;
    for (int k = 0; k < 2000; k++, t += 2e-4) {
        value = 2.0 * sin(20.0 * t);
        EXPECT(fmi3SetFloat64(c, &input, 1, &value, 1), fmi3OK);
        EXPECT(fmi3DoStep(c, t, 2e-4, true, &event, &terminate, &early, &last_time), fmi3OK);
        if (event) {
            EXPECT(fmi3EnterEventMode(c), fmi3OK);
            EXPECT(fmi3UpdateDiscreteStates(c, &need, &terminate, &nominals, &values, &defined, &next_time), fmi3OK);
            EXPECT(fmi3EnterStepMode(c), fmi3OK);
        }
        if (k == 1000) EXPECT(fmi3GetFMUState(c, &state), fmi3OK);
    }
    size_t size = 0;
    EXPECT(fmi3SerializedFMUStateSize(c, state, &size), fmi3OK);
    fmi3Byte *bytes = malloc(size);
    EXPECT(fmi3SerializeFMUState(c, state, bytes, size), fmi3OK);
    EXPECT(fmi3DeserializeFMUState(c, bytes, size, &copy), fmi3OK);
    EXPECT(fmi3SetFMUState(c, copy), fmi3OK);
    EXPECT(fmi3FreeFMUState(c, &copy), fmi3OK);
    EXPECT(fmi3FreeFMUState(c, &state), fmi3OK);
    EXPECT(fmi3DeserializeFMUState(c, bytes, size / 2, &copy), fmi3Error); /* truncated bytes */
    free(bytes);
    EXPECT(fmi3Reset(c), fmi3OK);

    /* misuse: every case returns fmi3Error, then reset recovers */
    fmi3ValueReference unknown = 9999;
    double nan_value = NAN, negative = -1.0;
    EXPECT(fmi3DoStep(c, 0.0, 1e-3, true, &event, &terminate, &early, &last_time), fmi3Error);
    EXPECT(fmi3Reset(c), fmi3OK);
    EXPECT(fmi3GetFloat64(c, &unknown, 1, out, 1), fmi3Error);
    EXPECT(fmi3Reset(c), fmi3OK);
    EXPECT(fmi3SetFloat64(c, &parameter, 1, &negative, 1), fmi3Error);
    EXPECT(fmi3Reset(c), fmi3OK);
    EXPECT(fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0), fmi3OK);
    EXPECT(fmi3SetFloat64(c, &input, 1, &nan_value, 1), fmi3Error);
    EXPECT(fmi3Terminate(c), fmi3Error);
    fmi3FreeInstance(c);

    /* a wrong token is refused */
    if (fmi3InstantiateCoSimulation("bad", "{not-a-token}", resources, false, false, false, false, NULL, 0, NULL,
                                    logger, NULL))
        return 1;

    /* Model Exchange sequence */
    fmi3Instance m = fmi3InstantiateModelExchange("me", token, resources, false, false, NULL, logger);
    if (!m) return 1;
    EXPECT(fmi3EnterInitializationMode(m, false, 0.0, 0.0, false, 0.0), fmi3OK);
    EXPECT(fmi3ExitInitializationMode(m), fmi3OK);
    EXPECT(fmi3UpdateDiscreteStates(m, &need, &terminate, &nominals, &values, &defined, &next_time), fmi3OK);
    EXPECT(fmi3EnterContinuousTimeMode(m), fmi3OK);
    double x[8], dx[8], z[8];
    fmi3Boolean enter = false;
    for (int k = 0; k < 100; k++) {
        EXPECT(fmi3SetTime(m, k * 1e-4), fmi3OK);
        EXPECT(fmi3GetContinuousStates(m, x, n_states), fmi3OK);
        EXPECT(fmi3GetContinuousStateDerivatives(m, dx, n_states), fmi3OK);
        for (size_t j = 0; j < n_states; j++) x[j] += 1e-4 * dx[j];
        EXPECT(fmi3SetContinuousStates(m, x, n_states), fmi3OK);
        EXPECT(fmi3GetEventIndicators(m, z, n_indicators), fmi3OK);
        EXPECT(fmi3CompletedIntegratorStep(m, true, &enter, &terminate), fmi3OK);
        if (enter || (defined && k * 1e-4 >= next_time)) {
            EXPECT(fmi3EnterEventMode(m), fmi3OK);
            EXPECT(fmi3UpdateDiscreteStates(m, &need, &terminate, &nominals, &values, &defined, &next_time), fmi3OK);
            EXPECT(fmi3EnterContinuousTimeMode(m), fmi3OK);
        }
    }
    EXPECT(fmi3GetContinuousStateDerivatives(m, dx, n_states + 1), fmi3Error);
    fmi3FreeInstance(m);

    /* instantiate/free cycles */
    for (int k = 0; k < 200; k++) {
        fmi3Instance cycle = fmi3InstantiateCoSimulation("cycle", token, resources, false, false, false, false, NULL, 0,
                                                         NULL, logger, NULL);
        if (!cycle) return 1;
        fmi3FreeInstance(cycle);
    }
    dlclose(library);
    return errors_logged > 0 ? 0 : 1; /* the misuse cases must have been logged */
}
