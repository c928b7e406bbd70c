/* Exercises one FMU binary through its fmi2 functions, for valgrind memcheck (tests/test_memcheck.py):
 * a Co-Simulation run with FMU state save/restore/serialize, a Model Exchange sequence, the misuse
 * cases that must return fmi2Error, a wrong GUID, and instantiate/free cycles.
 * Usage: driver LIBRARY GUID RESOURCE_URI INPUT_VR PARAMETER_VR N_STATES N_INDICATORS */
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(library, #name); if (!name) { fprintf(stderr, "no %s\n", #name); return 2; }
#define EXPECT(call, status) do { if ((call) != (status)) { fprintf(stderr, "line %d: %s did not return %d\n", __LINE__, #call, status); return 1; } } while (0)

static int errors_logged = 0;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env, (void)name, (void)category, (void)message;
    if (status == fmi2Error) errors_logged++;
}

int main(int argc, char **argv) {
    if (argc != 8) return 2;
    void *library = dlopen(argv[1], RTLD_NOW);
    if (!library) { fprintf(stderr, "%s\n", dlerror()); return 2; }
    const char *guid = argv[2], *resources = argv[3];
    fmi2ValueReference input = (fmi2ValueReference)atoi(argv[4]), parameter = (fmi2ValueReference)atoi(argv[5]);
    size_t n_states = (size_t)atoi(argv[6]), n_indicators = (size_t)atoi(argv[7]);
    LOAD(fmi2Instantiate) LOAD(fmi2FreeInstance) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2DoStep) LOAD(fmi2SetReal) LOAD(fmi2GetReal) LOAD(fmi2Reset)
    LOAD(fmi2GetFMUstate) LOAD(fmi2SetFMUstate) LOAD(fmi2FreeFMUstate) LOAD(fmi2SerializedFMUstateSize)
    LOAD(fmi2SerializeFMUstate) LOAD(fmi2DeSerializeFMUstate) LOAD(fmi2Terminate) LOAD(fmi2SetRealInputDerivatives)
    LOAD(fmi2GetDerivatives) LOAD(fmi2GetEventIndicators) LOAD(fmi2NewDiscreteStates) LOAD(fmi2EnterContinuousTimeMode)
    LOAD(fmi2SetContinuousStates) LOAD(fmi2GetContinuousStates) LOAD(fmi2CompletedIntegratorStep) LOAD(fmi2SetTime)
    LOAD(fmi2EnterEventMode) LOAD(fmi2SetDebugLogging)
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

    /* Co-Simulation with state save, restore and serialization */
    fmi2Component c = fmi2Instantiate("cs", fmi2CoSimulation, guid, resources, &callbacks, fmi2False, fmi2True);
    if (!c) return 1;
    EXPECT(fmi2SetDebugLogging(c, fmi2True, 0, NULL), fmi2OK);
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    EXPECT(fmi2EnterInitializationMode(c), fmi2OK);
    EXPECT(fmi2ExitInitializationMode(c), fmi2OK);
    double t = 0.0, value = 1.5, out[4];
    fmi2FMUstate state = NULL, copy = NULL;
    for (int k = 0; k < 2000; k++, t += 2e-4) {
        value = 2.0 * sin(20.0 * t);
        EXPECT(fmi2SetReal(c, &input, 1, &value), fmi2OK);
        fmi2Integer order = 1;
        double slope = 40.0 * cos(20.0 * t);
        EXPECT(fmi2SetRealInputDerivatives(c, &input, 1, &order, &slope), fmi2OK);
        EXPECT(fmi2DoStep(c, t, 2e-4, fmi2True), fmi2OK);
        if (k == 1000) EXPECT(fmi2GetFMUstate(c, &state), fmi2OK);
    }
    size_t size = 0;
    EXPECT(fmi2SerializedFMUstateSize(c, state, &size), fmi2OK);
    fmi2Byte *bytes = malloc(size);
    EXPECT(fmi2SerializeFMUstate(c, state, bytes, size), fmi2OK);
    EXPECT(fmi2DeSerializeFMUstate(c, bytes, size, &copy), fmi2OK);
    EXPECT(fmi2SetFMUstate(c, copy), fmi2OK);
    EXPECT(fmi2FreeFMUstate(c, &copy), fmi2OK);
    EXPECT(fmi2FreeFMUstate(c, &state), fmi2OK);
    EXPECT(fmi2DeSerializeFMUstate(c, bytes, size / 2, &copy), fmi2Error); /* truncated bytes */
    free(bytes);
    EXPECT(fmi2Reset(c), fmi2OK);

    /* misuse: every case returns fmi2Error, then reset recovers */
    fmi2ValueReference unknown = 9999;
    double nan_value = NAN, negative = -1.0;
    EXPECT(fmi2DoStep(c, 0.0, 1e-3, fmi2True), fmi2Error);
    EXPECT(fmi2Reset(c), fmi2OK);
    EXPECT(fmi2GetReal(c, &unknown, 1, out), fmi2Error);
    EXPECT(fmi2Reset(c), fmi2OK);
    EXPECT(fmi2SetReal(c, &parameter, 1, &negative), fmi2Error);
    EXPECT(fmi2Reset(c), fmi2OK);
    EXPECT(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    EXPECT(fmi2EnterInitializationMode(c), fmi2OK);
    EXPECT(fmi2SetReal(c, &input, 1, &nan_value), fmi2Error);
    EXPECT(fmi2Terminate(c), fmi2Error);
    fmi2FreeInstance(c);

    /* a wrong GUID is refused */
    if (fmi2Instantiate("bad", fmi2CoSimulation, "{not-a-guid}", resources, &callbacks, fmi2False, fmi2False)) return 1;

    /* Model Exchange sequence */
    fmi2Component m = fmi2Instantiate("me", fmi2ModelExchange, guid, resources, &callbacks, fmi2False, fmi2False);
    if (!m) return 1;
    EXPECT(fmi2SetupExperiment(m, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
    EXPECT(fmi2EnterInitializationMode(m), fmi2OK);
    EXPECT(fmi2ExitInitializationMode(m), fmi2OK);
    fmi2EventInfo info;
    EXPECT(fmi2NewDiscreteStates(m, &info), fmi2OK);
    EXPECT(fmi2EnterContinuousTimeMode(m), fmi2OK);
    double x[8], dx[8], z[8];
    fmi2Boolean enter = fmi2False, terminate = fmi2False;
    for (int k = 0; k < 100; k++) {
        EXPECT(fmi2SetTime(m, k * 1e-4), fmi2OK);
        EXPECT(fmi2GetContinuousStates(m, x, n_states), fmi2OK);
        EXPECT(fmi2GetDerivatives(m, dx, n_states), fmi2OK);
        for (size_t j = 0; j < n_states; j++) x[j] += 1e-4 * dx[j];
        EXPECT(fmi2SetContinuousStates(m, x, n_states), fmi2OK);
        EXPECT(fmi2GetEventIndicators(m, z, n_indicators), fmi2OK);
        EXPECT(fmi2CompletedIntegratorStep(m, fmi2True, &enter, &terminate), fmi2OK);
        if (enter) {
            EXPECT(fmi2EnterEventMode(m), fmi2OK);
            EXPECT(fmi2NewDiscreteStates(m, &info), fmi2OK);
            EXPECT(fmi2EnterContinuousTimeMode(m), fmi2OK);
        }
    }
    EXPECT(fmi2GetDerivatives(m, dx, n_states + 1), fmi2Error);
    fmi2FreeInstance(m);

    /* instantiate/free cycles */
    for (int k = 0; k < 200; k++) {
        fmi2Component cycle = fmi2Instantiate("cycle", fmi2CoSimulation, guid, resources, &callbacks, fmi2False, fmi2False);
        if (!cycle) return 1;
        fmi2FreeInstance(cycle);
    }
    dlclose(library);
    return errors_logged > 0 ? 0 : 1; /* the misuse cases must have been logged */
}
