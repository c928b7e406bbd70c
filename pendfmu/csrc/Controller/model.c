/* Controller: a discrete PID controller with sample time, derivative over n_d samples,
 * pure output delay, saturation and a feedforward added after the saturation.
 *
 * Samples. The controller samples at t_k = t_start + k T_s, k = 0, 1, 2, ... (t_start: the
 * start time of the experiment; t_k is computed by multiplication, never by accumulation).
 * At sample k it reads the inputs r, y and u_ff at that instant and computes
 *
 *     e_k = r_k - y_k
 *     s_k = -y_k if derivative_on_measurement, else e_k        (the signal the D term acts on)
 *     D_k = K_d (s_k - s_{k-n_d}) / (n_d T_s)                  (s_{j} = s_0 for j < 0: D_0 = 0)
 *     v_k = K_p e_k + I_k + D_k                                (I_0 = 0)
 *     w_k = min(u_max, max(u_min, v_k))                        (saturation)
 *     u_k = w_{k-delay} + u_ff_k                               (w_j = u0 for j < 0)
 *     I_{k+1} = I_k + K_i T_s e_k, except that the integrator holds (clamping anti-windup)
 *               when v_k > u_max and K_i e_k > 0, or v_k < u_min and K_i e_k < 0.
 *
 * The output u changes at t_k and is held until t_{k+1} (before t_0: u0 + u_ff). Saturating
 * before the delay line is the same as after it (both act sample by sample).
 *
 * EMPS (nonlinearbenchmark.org): nu = kv (kp (qr - q) - dq_hat), dq_hat = (q_k - q_{k-2})/(2 dt),
 * one sample of delay, +/-10 V, pulses added after: K_p = kv kp, K_i = 0, K_d = kv,
 * derivative_on_measurement, n_d = 2, delay = 1, u_max = 10, u_min = -10, u_ff = pulses.
 *
 * Model Exchange: every sample is a time event (fmi2NewDiscreteStates takes it and announces
 * t_{k+1} as nextEventTime). Co-Simulation: fmi2DoStep(t, h) takes the samples in [t, t + h):
 * one at t with the inputs the master set at t, the ones inside with the inputs held (or
 * interpolated, after fmi2SetRealInputDerivatives). A sample at t + h is taken by the next
 * step, so that it sees the inputs the master sets at t + h; until then u already shows its
 * value for the current inputs (a preview, recomputed when the inputs change). So with a
 * communication step equal to T_s, the controller samples at each communication point with
 * the inputs just set there, and u read at that point is the sample's output.
 *
 * Continuous states: none. The discrete state (integrator, the last n_d values of s, the
 * delay line) lives in DynamicState.store, so FMU states save and restore it.
 */
#include <math.h>
#include <stdio.h>

#include "framework.h"

/* The longest derivative span and delay, in samples (CONTROLLER_MAX_SAMPLES in
 * pendfmu/components.py, which sizes the store). */
#define MAX_SAMPLES 100

/* The part of a sample time by which a Co-Simulation communication point may miss a sample
 * and still be it (model_time_event_window). */
#define SAMPLE_JITTER 0.01

/* Store layout: scalars, then s_{k-1} ... s_{k-n_d}, then w_{k-1} ... w_{k-delay}. */
enum { ST_T0 = 0, ST_K = 1, ST_I = 2, ST_HISTORY = 8, ST_DELAY = ST_HISTORY + MAX_SAMPLES,
       ST_SIZE = ST_DELAY + MAX_SAMPLES };

/* The store must hold the layout (a negative array size fails the build otherwise). */
typedef char store_is_large_enough[MODEL_STORE_SIZE >= ST_SIZE ? 1 : -1];

#define INT(name) (inst->s.i[VR_##name - VR_INTEGER_BASE])

bool model_check_parameters(const Instance *inst, char *why, size_t size) {
    if (!(R(T_s) > 0.0)) {
        snprintf(why, size, "Controller: the sample time T_s = %g s must be > 0", R(T_s));
        return false;
    }
    if (!sample_time_resolved(inst, "Controller", R(T_s), why, size)) return false;
    if (INT(n_d) < 1 || INT(n_d) > MAX_SAMPLES) {
        snprintf(why, size, "Controller: the derivative span n_d = %d samples must be in 1..%d", INT(n_d),
                 MAX_SAMPLES);
        return false;
    }
    if (INT(delay) < 0 || INT(delay) > MAX_SAMPLES) {
        snprintf(why, size, "Controller: the output delay = %d samples must be in 0..%d", INT(delay), MAX_SAMPLES);
        return false;
    }
    if (!(R(u_min) <= R(u_max))) {
        snprintf(why, size, "Controller: the saturation u_min = %g is above u_max = %g", R(u_min), R(u_max));
        return false;
    }
    return true;
}

void model_initial_states(Instance *inst) {
    double *store = inst->s.store;
    for (int j = 0; j < MODEL_STORE_SIZE; j++) store[j] = 0.0;
    store[ST_T0] = inst->s.time;
    for (int j = 0; j < INT(delay); j++) store[ST_DELAY + j] = R(u0);
    R(u) = R(u0) + R(u_ff);
    R(e) = 0.0;
    R(v) = 0.0;
    R(u_I) = 0.0;
    R(t_sample) = inst->s.time;
    MODE = 0;
    FLAG(saturated) = false;
}

/* No continuous dynamics: the framework's integrator has nothing to do; outputs change at samples only. */
NO_CONTINUOUS_DYNAMICS

SAMPLED_EVERY_T_S(ST_T0, ST_K, SAMPLE_JITTER)

void model_time_event(Instance *inst, double t, bool commit) {
    double *store = inst->s.store;
    const int n_d = INT(n_d), delay = INT(delay);
    const bool first = store[ST_K] == 0.0;
    const double e = R(r) - R(y);
    const double s = FLAG(derivative_on_measurement) ? -R(y) : e;
    const double s_past = first ? s : store[ST_HISTORY + n_d - 1];
    const double d = R(K_d) * (s - s_past) / (n_d * R(T_s));
    const double v = R(K_p) * e + store[ST_I] + d;
    const double w = v > R(u_max) ? R(u_max) : (v < R(u_min) ? R(u_min) : v);
    R(u) = (delay == 0 ? w : store[ST_DELAY + delay - 1]) + R(u_ff);
    if (!commit) return;

    /* Take the sample: shift the histories, integrate, advance k. */
    if (first)
        for (int j = 0; j < n_d; j++) store[ST_HISTORY + j] = s;
    for (int j = n_d - 1; j > 0; j--) store[ST_HISTORY + j] = store[ST_HISTORY + j - 1];
    store[ST_HISTORY] = s;
    for (int j = delay - 1; j > 0; j--) store[ST_DELAY + j] = store[ST_DELAY + j - 1];
    if (delay > 0) store[ST_DELAY] = w;
    const double increment = R(K_i) * R(T_s) * e;
    if (!((v > R(u_max) && increment > 0.0) || (v < R(u_min) && increment < 0.0))) store[ST_I] += increment;
    store[ST_K] += 1.0;

    const int mode = v > R(u_max) ? 1 : (v < R(u_min) ? -1 : 0);
    if (mode != MODE) {
        log_event(inst, "t = %.12g s: saturation %d -> %d", t, MODE, mode);
        inst->s.event_count++;
        R(t_mode) = t;
        MODE = mode;
    }
    FLAG(saturated) = mode != 0;
    R(e) = e;
    R(v) = v;
    R(u_I) = store[ST_I];
    R(t_sample) = t;
}
