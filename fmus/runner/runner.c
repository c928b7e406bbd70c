/* A native communication loop over one Co-Simulation FMU instance.
 *
 * The loop a fit runs thousands of times: at every communication point set the inputs,
 * read the outputs, step to the next point. It calls the FMU's own fmi2 functions through
 * pointers taken from the library fmpy loaded (so the instance is fmpy's, set up and
 * parameterized by it) and does exactly what the Python loop does, in the same order, so
 * the results are bit-identical; only the per-step overhead of Python and ctypes is gone.
 */
#include <stddef.h>

#include "fmi2Functions.h"

typedef struct {
    fmi2Component component;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2SetRealInputDerivativesTYPE *set_input_derivatives;
} Unit;

/* Run through n_points communication points. inputs is n_points x n_inputs (row-major),
 * outputs n_points x n_outputs; slopes (or NULL: inputs held) gives each input's first
 * derivative over the step that starts at each point. Returns -1 on success, else the
 * index of the point where an fmi2 call failed (the FMU has logged why). */
__attribute__((visibility("default")))
long pendfmu_run_single(const Unit *unit, size_t n_points, const double *times,
                        size_t n_inputs, const fmi2ValueReference *input_vrs, const double *inputs,
                        const double *slopes, size_t n_outputs, const fmi2ValueReference *output_vrs,
                        double *outputs) {
    fmi2Integer first_order[64];
    if (n_inputs > 64) return 0;
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
