/* RigController: balance and swing-up controller of the pendulum rig, designed by `pendfmu control`.
 *
 * The twin of pendfmu/control/law.py and plant.py, operation for operation (the two must agree
 * sample by sample: tests/test_control.py). At each sample t_k = t_start + k T_s, from the
 * encoder readings x and phi (continuous; wrapped here into (-pi, pi], 0 upright):
 *
 *   1. correct the estimate predicted at the last sample, s = (x, v, phi, w, I), with the
 *      innovations of x and phi (gains L; phi's innovation wrapped);
 *   2. balance near upright (LQR gains K: on the self-locking axis they give the cart's
 *      acceleration, turned into a drive force by the cart's inverse model; else the current),
 *      else (swing_up) the energy law: pump against w cos(phi) in proportion to the energy
 *      missing to upright, within a_swing, centring springs on the cart;
 *   3. add the friction the cart is believed to have (compensation: Coulomb against a sliding
 *      cart, the breakaway force, ramped in over F_ramp, for a stuck one) and limit the
 *      current to +-I_max: that is I_c, held until the next sample; balancing on a
 *      self-locking screw, a stuck cart wanted to push less than F_ramp gets none (holds);
 *   4. predict the next sample's state under I_c (RK2, SUBSTEPS steps of the paper's current
 *      loop, cart and pendulum (docs/user-guide/model.md), the compensated friction left out).
 *
 * Co-Simulation and Model Exchange take the samples as the Controller component does (its
 * model.c): a sample at a communication point reads the inputs set there; without commit the
 * output previews the sample for the current inputs and leaves the state alone.
 */
#include <math.h>
#include <stdio.h>

#include "framework.h"

#define SAMPLE_JITTER 0.01
#define SUBSTEPS 10
#define N_S 5
#define TRACK_USE 0.9 /* of x_max: where the swing-up's braking aims to stop (law.py) */

enum { SWING = 0, BALANCE = 1 };
/* Store layout: first sample time, sample count, predicted state (5), mode, cancelled force. */
enum { ST_T0 = 0, ST_K = 1, ST_S = 2, ST_MODE = ST_S + N_S, ST_CANCELLED = ST_MODE + 1, ST_SIZE = ST_CANCELLED + 1 };

typedef char store_is_large_enough[MODEL_STORE_SIZE >= ST_SIZE ? 1 : -1];

static double wrap(double angle) {
    double wrapped = fmod(angle + PI, 2.0 * PI);
    if (wrapped <= 0.0) wrapped += 2.0 * PI;
    return wrapped - PI;
}

static double sgn(double value) { return value >= 0.0 ? 1.0 : -1.0; }

/* The input rounded to a multiple of step (halves up), or as it is for step 0: an encoder
 * emulated when the loop is closed on a continuous model (law.py's quantized). */
static double quantized(double value, double step) { return step > 0.0 ? floor(value / step + 0.5) * step : value; }

static double clamp(double value, double limit) { return fmax(-limit, fmin(limit, value)); }

static void accelerations(const Instance *inst, double v, double phi, double w, double force, double *a,
                          double *alpha) {
    const double s = sin(phi), c = cos(phi);
    const double b1 = force - R(k_fwc) * v + R(A_back) * R(m_p) * R(l) * w * w * s;
    const double b2 = R(m_p) * R(l) * R(g) * s - R(k_fwp) * w;
    const double a12 = R(A_back) * R(m_p) * R(l) * c;
    const double a21 = R(m_p) * R(l) * c;
    const double det = R(M) * R(J_p) - a12 * a21;
    *a = (b1 * R(J_p) - a12 * b2) / det;
    *alpha = (R(M) * b2 - a21 * b1) / det;
}

static double cart_force(const Instance *inst, double a, double v, double phi, double w) {
    const double s = sin(phi), c = cos(phi);
    const double alpha = (R(m_p) * R(l) * (R(g) * s - a * c) - R(k_fwp) * w) / R(J_p);
    return R(M) * a + R(k_fwc) * v - R(A_back) * R(m_p) * R(l) * (w * w * s - alpha * c);
}

static double current_rate(const Instance *inst, double I, double I_c) {
    const double z = (I_c - I) / (R(T_i) * R(dIdt_max));
    return R(dIdt_max) * fmax(-1.0, fmin(1.0, z));
}

static void derivative(const Instance *inst, const double *s, double I_c, double cancelled, double *ds) {
    double a, alpha;
    accelerations(inst, s[1], s[2], s[3], R(eta) * R(k_F) * s[4] - cancelled, &a, &alpha);
    ds[0] = s[1], ds[1] = a, ds[2] = s[3], ds[3] = alpha, ds[4] = current_rate(inst, s[4], I_c);
}

static void predict(const Instance *inst, double *s, double I_c, double cancelled) {
    const double h = R(T_s) / SUBSTEPS;
    double d1[N_S], d2[N_S], mid[N_S];
    for (int step = 0; step < SUBSTEPS; step++) {
        derivative(inst, s, I_c, cancelled, d1);
        for (int j = 0; j < N_S; j++) mid[j] = s[j] + 0.5 * h * d1[j];
        derivative(inst, mid, I_c, cancelled, d2);
        for (int j = 0; j < N_S; j++) s[j] = s[j] + h * d2[j];
    }
    s[2] = wrap(s[2]);
}

static void correct(const Instance *inst, const double *store, double x, double phi, double *s) {
    if (store[ST_K] == 0.0) {
        s[0] = x, s[1] = 0.0, s[2] = phi, s[3] = 0.0, s[4] = 0.0;
        return;
    }
    const double *predicted = store + ST_S;
    const double gain[N_S][2] = {{R(Lx_x), R(Lx_phi)}, {R(Lv_x), R(Lv_phi)}, {R(Lphi_x), R(Lphi_phi)},
                                 {R(Lw_x), R(Lw_phi)}, {R(LI_x), R(LI_phi)}};
    const double e_x = x - predicted[0], e_phi = wrap(phi - predicted[2]);
    for (int j = 0; j < N_S; j++) s[j] = predicted[j] + gain[j][0] * e_x + gain[j][1] * e_phi;
    s[2] = wrap(s[2]);
}

static int choose_mode(const Instance *inst, const double *s, int previous) {
    if (!FLAG(swing_up)) return BALANCE;
    const double limit = previous == SWING ? R(phi_catch) : 2.0 * R(phi_catch);
    return fabs(s[2]) < limit ? BALANCE : SWING;
}

static double balance_force(const Instance *inst, const double *s, double x_ref, double cancelled) {
    if (FLAG(axis)) {
        double a, alpha;
        accelerations(inst, s[1], s[2], s[3], R(eta) * R(k_F) * s[4] - cancelled, &a, &alpha);
        const double a_c = -(R(K_x) * (s[0] - x_ref) + R(K_v) * s[1] + R(K_phi) * s[2] + R(K_w) * s[3] +
                             R(K_drive) * a);
        return cart_force(inst, a_c, s[1], s[2], s[3]);
    }
    const double I = -(R(K_x) * (s[0] - x_ref) + R(K_v) * s[1] + R(K_phi) * s[2] + R(K_w) * s[3] +
                       R(K_drive) * s[4]);
    return R(eta) * R(k_F) * I;
}

/* The track limit (law.py's within_track): a cart heading for an end that could only just stop
 * before TRACK_USE of x_max at the swing's acceleration limit brakes at that limit. */
static double within_track(const Instance *inst, double a, double x, double v) {
    const double room = TRACK_USE * R(x_max) - fabs(x);
    if (x * v > 0.0 && v * v >= 2.0 * R(a_swing) * room) return -sgn(v) * R(a_swing);
    return a;
}

static double swing_acceleration(const Instance *inst, const double *s, double x_ref) {
    const double E = 0.5 * R(J_p) * (s[3] * s[3]) + R(m_p) * R(g) * R(l) * (cos(s[2]) - 1.0);
    double pump = R(k_E) * E / (R(m_p) * R(g) * R(l)) * sgn(s[3] * cos(s[2]));
    pump = fmax(-R(a_swing), fmin(R(a_swing), pump));
    return within_track(inst, pump - R(k_xs) * (s[0] - x_ref) - R(k_vs) * s[1], s[0], s[1]);
}

/* law.py's holds: balancing on a self-locking screw, a stuck cart wanted to push less than F_ramp holds itself. */
static bool holds(const Instance *inst, int mode, double force, double v) {
    return FLAG(axis) && FLAG(compensation) && mode == BALANCE && fabs(v) <= R(v_stuck) && fabs(force) < R(F_ramp);
}

static double compensation(const Instance *inst, double force, double v) {
    if (!FLAG(compensation)) return 0.0;
    if (fabs(v) > R(v_stuck)) return R(F_Kc) * sgn(v);
    return R(F_Sc) * fmax(-1.0, fmin(1.0, force / R(F_ramp)));
}

bool model_check_parameters(const Instance *inst, char *why, size_t size) {
    const struct { const char *name; double value; } positive[] = {
        {"T_s", R(T_s)}, {"M", R(M)}, {"m_p", R(m_p)}, {"l", R(l)}, {"J_p", R(J_p)}, {"eta", R(eta)},
        {"k_F", R(k_F)}, {"T_i", R(T_i)}, {"dIdt_max", R(dIdt_max)}, {"I_max", R(I_max)}, {"F_ramp", R(F_ramp)}};
    for (size_t j = 0; j < sizeof positive / sizeof positive[0]; j++)
        if (!(positive[j].value > 0.0)) {
            snprintf(why, size, "RigController: %s = %g must be > 0", positive[j].name, positive[j].value);
            return false;
        }
    if (!(R(x_quantum) >= 0.0) || !(R(phi_quantum) >= 0.0)) {
        snprintf(why, size, "RigController: x_quantum = %g and phi_quantum = %g must be >= 0", R(x_quantum),
                 R(phi_quantum));
        return false;
    }
    return sample_time_resolved(inst, "RigController", R(T_s), why, size);
}

void model_initial_states(Instance *inst) {
    double *store = inst->s.store;
    for (int j = 0; j < MODEL_STORE_SIZE; j++) store[j] = 0.0;
    store[ST_T0] = inst->s.time;
    store[ST_MODE] = BALANCE;
    R(I_c) = 0.0;
    R(x_hat) = quantized(R(x), R(x_quantum)), R(v_hat) = 0.0, R(phi_hat) = wrap(quantized(R(phi), R(phi_quantum)));
    R(w_hat) = 0.0, R(I_hat) = 0.0;
    R(cancelled) = 0.0;
    R(t_mode) = inst->s.time;
    MODE = BALANCE;
}

/* No continuous dynamics: the framework's integrator has nothing to do; outputs change at samples only. */
NO_CONTINUOUS_DYNAMICS

SAMPLED_EVERY_T_S(ST_T0, ST_K, SAMPLE_JITTER)

void model_time_event(Instance *inst, double t, bool commit) {
    double *store = inst->s.store;
    double s[N_S];
    correct(inst, store, quantized(R(x), R(x_quantum)), wrap(quantized(R(phi), R(phi_quantum))), s);
    const int mode = choose_mode(inst, s, (int)store[ST_MODE]);
    double force = mode == BALANCE ? balance_force(inst, s, R(x_ref), store[ST_CANCELLED])
                                   : cart_force(inst, swing_acceleration(inst, s, R(x_ref)), s[1], s[2], s[3]);
    double cancelled = 0.0;
    if (holds(inst, mode, force, s[1]))
        force = 0.0;
    else
        cancelled = compensation(inst, force, s[1]);
    const double I_c = clamp((force + cancelled) / (R(eta) * R(k_F)), R(I_max));
    R(I_c) = I_c;
    if (!commit) return;

    R(x_hat) = s[0], R(v_hat) = s[1], R(phi_hat) = s[2], R(w_hat) = s[3], R(I_hat) = s[4];
    R(cancelled) = cancelled;
    if (mode != MODE) {
        log_event(inst, "t = %.12g s: %s -> %s", t, MODE == BALANCE ? "balance" : "swing-up",
                  mode == BALANCE ? "balance" : "swing-up");
        inst->s.event_count++;
        R(t_mode) = t;
        MODE = mode;
    }
    predict(inst, s, I_c, cancelled);
    for (int j = 0; j < N_S; j++) store[ST_S + j] = s[j];
    store[ST_MODE] = mode;
    store[ST_CANCELLED] = cancelled;
    store[ST_K] += 1.0;
}
