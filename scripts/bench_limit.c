/* The limit for scripts/bench.py: the rig's FMUs stepped in the plainest possible C loop
 * (inputs held, outputs copied along the connections, phi recorded at every point as the
 * other loops of the benchmark do). Built by the benchmark with the FMUs' toolchain; not part of pendfmu. */
#include "runner.h" /* Unit: the C view of an instance that pendfmu's native.unit_of makes */

/* units[0] -> units[1] -> units[2]: CurrentLoop.I_mean -> Cart.I, Cart.a -> Pendulum.a */
__attribute__((visibility("default")))
int bench_limit(const Unit *units, const fmi2ValueReference *vr, size_t n_steps, double h, double command,
                double *recorded) {
    /* vr: CurrentLoop.I_c, CurrentLoop.I_mean, Cart.I, Cart.a, Pendulum.a, Pendulum.phi */
    double current = 0.0, acceleration = 0.0, t = 0.0;
    units[2].get_real(units[2].component, &vr[5], 1, &recorded[0]);
    for (size_t k = 0; k < n_steps; k++, t = (double)k * h) {
        if (units[0].set_real(units[0].component, &vr[0], 1, &command) > fmi2Warning) return 0;
        if (units[0].do_step(units[0].component, t, h, fmi2True) > fmi2Warning) return 0;
        units[0].get_real(units[0].component, &vr[1], 1, &current);
        units[1].set_real(units[1].component, &vr[2], 1, &current);
        if (units[1].do_step(units[1].component, t, h, fmi2True) > fmi2Warning) return 0;
        units[1].get_real(units[1].component, &vr[3], 1, &acceleration);
        units[2].set_real(units[2].component, &vr[4], 1, &acceleration);
        if (units[2].do_step(units[2].component, t, h, fmi2True) > fmi2Warning) return 0;
        units[2].get_real(units[2].component, &vr[5], 1, &recorded[k + 1]);
    }
    return 1;
}
