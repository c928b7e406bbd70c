/* CurrentLoop: the motor's current control loop as a slope-limited first-order lag
 * (paper Eq. 1, docs/user-guide/model.md):
 *
 *     dI/dt = dIdt_max * sat((I_c - I) / (T_i * dIdt_max))
 *
 * plus the PWM ripple on the output, I_out = I + a_h sin(2 pi f_h t + phase_h).
 * The corner of sat() is an event (mode -1 / 0 / +1), so that the integrator never steps
 * across the kink: the ramp ends, and the exponential begins, at a located instant.
 */
#include <math.h>

#include "framework.h"

static double band(const Instance *inst) { return R(T_i) * R(dIdt_max); }

bool model_check_parameters(const Instance *inst, char *why, size_t size) {
    (void)inst, (void)why, (void)size;
    return true; /* the ranges of the variable table say all */
}

void model_initial_states(Instance *inst) {
    inst->s.x[S_I_mean] = R(I0);
    MODE = 0;
}

/* RK4 is only the fallback (inputs with second or third derivatives); T_i/10 keeps it accurate. */
double model_max_step(const Instance *inst) { return R(T_i) / 10.0; }

/* expm1(-h/T_i) for a step h, memoized (memo[0]: h, memo[1]: value): communication
 * steps repeat, and T_i is fixed once initialized. */
static double decay_of_step(Instance *inst, double h) {
    double *memo = inst->s.memo;
    if (!(memo[0] == h && h != 0.0)) {
        memo[0] = h;
        memo[1] = expm1(-h / R(T_i));
    }
    return memo[1];
}

/* The lag's exact solution for an input held or ramped over the step, u(t+s) = u + c s:
 *   saturated: I(t+h) = I + mode dIdt_max h
 *   linear:    I(t+h) = I + c h + (I - u + c T) (exp(-h/T) - 1)
 * (expm1 keeps it accurate for h << T). */
bool model_exact_step(Instance *inst, double t, const double *x, double h, double *x_out) {
    (void)t;
    double slope;
    if (!input_is_linear(inst, VR_I_c, &slope)) return false;
    const double I = x[S_I_mean];
    if (MODE != 0) {
        x_out[S_I_mean] = I + MODE * R(dIdt_max) * h;
    } else {
        x_out[S_I_mean] = I + slope * h + (I - R(I_c) + slope * R(T_i)) * decay_of_step(inst, h);
    }
    return true;
}

void model_derivatives(const Instance *inst, double t, const double *x, double *dx) {
    (void)t;
    dx[S_I_mean] = MODE == 0 ? (R(I_c) - x[S_I_mean]) / R(T_i) : MODE * R(dIdt_max);
}

void model_event_indicators(const Instance *inst, double t, const double *x, double *z) {
    (void)t;
    const double error = R(I_c) - x[S_I_mean];
    z[0] = MODE == 0 ? band(inst) - fabs(error) : MODE * error - band(inst);
}

bool model_update_mode(Instance *inst, double t, double *x) {
    (void)t;
    const double error = R(I_c) - x[S_I_mean];
    const int mode = fabs(error) <= band(inst) ? 0 : (error > 0.0 ? 1 : -1);
    const bool changed = mode != MODE;
    MODE = mode;
    return changed;
}

void model_outputs(Instance *inst, double t, const double *x) {
    double dx[N_STATES];
    model_derivatives(inst, t, x, dx);
    R(I_mean) = x[S_I_mean];
    R(der_I_mean) = dx[S_I_mean];
    R(I) = x[S_I_mean] + R(a_h) * sin(2.0 * PI * R(f_h) * t + R(phase_h));
    FLAG(saturated) = MODE != 0;
}

/* No time events: a continuous model. */
NO_TIME_EVENTS
