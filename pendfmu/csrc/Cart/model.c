/* Cart: the cart on the lead screw, driven by the motor (paper Eq. 2-5, docs/user-guide/model.md):
 *
 *     (m_c + m_p) a = F_A - F_F
 *     F_A = eta k_M k_D I + A(eta) m_p l (w^2 sin(phi) - alpha cos(phi))
 *     A(eta) = max(0, (2 eta - 1) / eta)
 *
 * A self-locking screw (eta <= 0.5) ignores the pendulum inputs; a back-drivable one
 * couples cart and pendulum accelerations (an algebraic loop the master solves).
 * F_F is the three-mode stick-slip friction of friction.h, with its optional extras
 * (Stribeck speed v_Sc, asymmetries dk_fwc and dF_Kc, offset force F_Oc; all 0 by default).
 *
 * Drives beyond the paper's model (docs/user-guide/drives.md; all off by default): a command u
 * beside the current, so that the motor force is
 *     F_u = k_M k_D I + F_cmd,   F_cmd = k_u u - k_emf v            (tau_e = 0)
 *                                tau_e dF_e/dt = k_u u - k_emf v - F_e,  F_cmd = F_e  (tau_e > 0)
 * and F_A = eta F_u + A m_p l (...) as in the paper's model (eta multiplies the whole motor force).
 * A is A(eta) unless eta_back >= 0 sets it: 0 self-locking whatever eta, else eta_back.
 */
#include <math.h>
#include <stdio.h>

#include "framework.h"
#include "friction.h"
#include "trig_memo.h"

/* Memo slots: the trigonometry of phi (back-drivable screw); phi functions of the last exact step */
enum { MEMO_TRIG = 0, MEMO_STEP = TRIG_MEMO_SLOTS, MEMO_PHI = MEMO_STEP + 1, MEMO_LAMBDA = MEMO_PHI + 3 };

static Friction friction(const Instance *inst) {
    const Friction f = {R(k_fwc), R(F_Kc), R(F_Sc), R(dk_fwc), R(dF_Kc), R(v_Sc), R(F_Oc), 0.0};
    return f;
}

/* The back-drive efficiency A: the paper's A(eta) while eta_back < 0, else eta_back itself
 * (0: self-locking whatever eta). */
static double back_drive(const Instance *inst) {
    const double eta = R(eta);
    if (R(eta_back) < 0.0) return eta <= 0.5 ? 0.0 : (2.0 * eta - 1.0) / eta;
    return R(eta_back);
}

/* Whether the command path exists (k_u, k_emf or tau_e set): without it the drive force is
 * the paper's, computed with the paper's arithmetic. */
static bool command_path(const Instance *inst) { return R(k_u) != 0.0 || R(k_emf) != 0.0 || R(tau_e) > 0.0; }

/* The command path's force before the screw: the lag's state, or k_u u - k_emf v at once. */
static double command_force(const Instance *inst, const double *x) {
    return R(tau_e) > 0.0 ? x[S_F_e] : R(k_u) * R(u) - R(k_emf) * x[S_v];
}

static double active_force(const Instance *inst, const double *x) {
    const double eta = R(eta);
    double drive = eta * R(k_M) * R(k_D) * R(I);
    if (command_path(inst)) drive += eta * command_force(inst, x);
    const double back = back_drive(inst);
    if (!(back > 0.0)) return drive; /* self-locking: the pendulum cannot push the cart */
    const double m_l = back * R(m_p) * R(l);
    /* A m_p l (w^2 sin phi - alpha cos phi) */
    return drive + trig_memo_wave(inst, MEMO_TRIG, R(phi), m_l * R(w) * R(w), -m_l * R(alpha));
}

bool model_check_parameters(const Instance *inst, char *why, size_t size) {
    if (R(eta_back) < 0.0 && R(eta_back) != -1.0) {
        snprintf(why, size, "eta_back = %g is neither -1 (the paper's A(eta)) nor a back-drive "
                 "efficiency in [0, 1] (0: self-locking whatever eta)", R(eta_back));
        return false;
    }
    return friction_asymmetry_ok(R(k_fwc), R(dk_fwc), "k_fwc", "dk_fwc", "N.s/m", why, size) &&
           friction_asymmetry_ok(R(F_Kc), R(dF_Kc), "F_Kc", "dF_Kc", "N", why, size);
}

void model_initial_states(Instance *inst) {
    const Friction f = friction(inst);
    inst->s.x[S_x] = R(x0);
    inst->s.x[S_v] = R(v0);
    inst->s.x[S_F_e] = 0.0; /* the lag starts from no force: a drive switched on at the start */
    MODE = friction_initial_mode(&f, R(v0), active_force(inst, inst->s.x));
}

/* Whether the exact step applies: a self-locking screw (the drive depends on I and u alone),
 * inputs I and u held or ramped over the step, no Stribeck term (which makes the equation
 * nonlinear in v) and no electrical lag (a third state). The back-EMF is linear in v: it
 * only adds eta k_emf to the viscous coefficient. */
static bool linear_over_step(const Instance *inst, double *slope, double *slope_u) {
    *slope_u = 0.0;
    return !(back_drive(inst) > 0.0) && !(R(v_Sc) > 0.0) && input_is_linear(inst, VR_I, slope) &&
           (!command_path(inst) || (!(R(tau_e) > 0.0) && input_is_linear(inst, VR_u, slope_u)));
}

/* The largest rate |d(F_F)/dv| the sliding law can have: the larger viscous coefficient,
 * plus the Stribeck slope's maximum |F_S - F_K| sqrt(2/e) / v_S (at v = v_S/sqrt(2)). */
static double friction_stiffness(const Instance *inst) {
    double stiffness = R(k_fwc) + fabs(R(dk_fwc));
    if (R(v_Sc) > 0.0)
        stiffness += (fabs(R(F_Sc) - R(F_Kc)) + fabs(R(dF_Kc))) * sqrt(2.0 / exp(1.0)) / R(v_Sc);
    return stiffness;
}

double model_max_step(const Instance *inst) {
    /* RK4 (with the pendulum coupled) is stable up to 2.78 time constants; stay well inside for
     * accuracy. The back-EMF adds eta k_emf to the viscous damping. */
    double stiffness = friction_stiffness(inst);
    if (R(k_emf) != 0.0) stiffness += R(eta) * R(k_emf);
    const double M = R(m_c) + R(m_p);
    if (R(tau_e) > 0.0) {
        /* The speed and the lag's force: d(v, F_e)/dt = J (v, F_e) + ..., with
         * J = [[-s/M, eta/M], [-k_emf/tau_e, -1/tau_e]] (s the friction's stiffness); 0.2 over
         * its spectral radius keeps the same margin as above. */
        const double s = friction_stiffness(inst), tau = R(tau_e);
        const double trace = -(s / M + 1.0 / tau), det = (s + R(eta) * R(k_emf)) / (M * tau);
        const double disc = trace * trace - 4.0 * det;
        const double radius = disc >= 0.0 ? 0.5 * (fabs(trace) + sqrt(disc)) : sqrt(det);
        return 0.2 / radius;
    }
    return stiffness > 0.0 ? 0.2 * M / stiffness : INFINITY;
}

/* phi[k-1] = phi_k(z) = sum_j z^j / (j+k)!, the functions of exponential integrators
 * (phi_1(z) = (e^z - 1)/z, phi_{k+1}(z) = (phi_k(z) - 1/k!)/z). Near z = 0 the closed
 * forms cancel, so phi_3 comes from its series and the others from the stable upward
 * recurrence phi_k = 1/k! + z phi_{k+1}. */
static void phi_functions(double z, double phi[3]) {
    static const double reciprocal[24] = {0, 1.0, 1.0 / 2, 1.0 / 3, 1.0 / 4, 1.0 / 5, 1.0 / 6, 1.0 / 7, 1.0 / 8,
                                          1.0 / 9, 1.0 / 10, 1.0 / 11, 1.0 / 12, 1.0 / 13, 1.0 / 14, 1.0 / 15,
                                          1.0 / 16, 1.0 / 17, 1.0 / 18, 1.0 / 19, 1.0 / 20, 1.0 / 21, 1.0 / 22,
                                          1.0 / 23};
    if (fabs(z) < 0.25) {
        double term = 1.0 / 6.0, sum = term;
        for (int j = 1; j < 20 && fabs(term) > 1e-18 * fabs(sum); j++) {
            term *= z * reciprocal[j + 3];
            sum += term;
        }
        phi[2] = sum;
        phi[1] = 0.5 + z * phi[2];
        phi[0] = 1.0 + z * phi[1];
    } else {
        phi[0] = expm1(z) / z;
        phi[1] = (phi[0] - 1.0) / z;
        phi[2] = (phi[1] - 0.5) / z;
    }
}

/* The phi functions for a step h (z = -lambda h), memoized by h and lambda: communication
 * steps repeat, and lambda changes only with the direction (dk_fwc != 0). */
static const double *phi_functions_of_step(Instance *inst, double lambda, double h) {
    double *memo = inst->s.memo;
    if (!(memo[MEMO_STEP] == h && h != 0.0 && memo[MEMO_LAMBDA] == lambda)) {
        memo[MEMO_STEP] = h;
        memo[MEMO_LAMBDA] = lambda;
        phi_functions(-lambda * h, &memo[MEMO_PHI]);
    }
    return &memo[MEMO_PHI];
}

/* The exact solution for a self-locking screw and I(t+s) = I + c s, u(t+s) = u + c_u s. Sliding,
 * the cart obeys
 *     v' = A + B s - lambda v,   A = (eta k_M k_D I + eta k_u u - F_K(mode) mode + F_Oc)/M,
 *     B = (eta k_M k_D c + eta k_u c_u)/M,  lambda = (k_fw(mode) + eta k_emf)/M,  M = m_c + m_p,
 *     (k_fw, F_K of the mode's direction: friction.h; the u and k_emf terms only with a command path)
 * a linear equation whose solution with z = -lambda h is
 *     v(h) = v + h phi_1(z) (A - lambda v) + h^2 phi_2(z) B
 *     x(h) = x + h v + h^2 phi_2(z) (A - lambda v) + h^3 phi_3(z) B.
 * Stuck, nothing moves. */
bool model_exact_step(Instance *inst, double t, const double *x, double h, double *x_out) {
    (void)t;
    double slope, slope_u;
    if (!linear_over_step(inst, &slope, &slope_u)) return false; /* pendulum coupling, Stribeck, lag: RK4 */
    x_out[S_F_e] = x[S_F_e]; /* no lag: its state stays as it is */
    if (MODE == 0) {
        x_out[S_x] = x[S_x];
        x_out[S_v] = x[S_v];
        return true;
    }
    const Friction f = friction(inst);
    const double M = R(m_c) + R(m_p), gain = R(eta) * R(k_M) * R(k_D) / M;
    double lambda = friction_viscous(&f, MODE) / M;
    double A = gain * R(I) - friction_coulomb(&f, MODE) * MODE / M + R(F_Oc) / M, B = gain * slope;
    if (command_path(inst)) {
        const double gain_u = R(eta) * R(k_u) / M;
        lambda = (friction_viscous(&f, MODE) + R(eta) * R(k_emf)) / M;
        A += gain_u * R(u);
        B += gain_u * slope_u;
    }
    const double pull = A - lambda * x[S_v];
    const double *phi = phi_functions_of_step(inst, lambda, h);
    x_out[S_v] = x[S_v] + h * phi[0] * pull + h * h * phi[1] * B;
    x_out[S_x] = x[S_x] + h * x[S_v] + h * h * phi[1] * pull + h * h * h * phi[2] * B;
    return true;
}

/* The cart's acceleration in the current mode: exactly 0 while stuck. The offset force
 * acts on the cart beside the active force (F_A stays the drive and the pendulum's push). */
static double acceleration(const Instance *inst, const Friction *f, double v, double F_A) {
    return MODE == 0 ? 0.0 : (F_A + f->F_O - friction_force(f, MODE, v, F_A)) / (R(m_c) + R(m_p));
}

void model_derivatives(const Instance *inst, double t, const double *x, double *dx) {
    (void)t;
    const Friction f = friction(inst);
    dx[S_x] = x[S_v];
    dx[S_v] = MODE == 0 ? 0.0 : acceleration(inst, &f, x[S_v], active_force(inst, x));
    dx[S_F_e] = R(tau_e) > 0.0 ? (R(k_u) * R(u) - R(k_emf) * x[S_v] - x[S_F_e]) / R(tau_e) : 0.0;
}

void model_event_indicators(const Instance *inst, double t, const double *x, double *z) {
    (void)t;
    const Friction f = friction(inst);
    const double F_A = MODE == 0 ? active_force(inst, x) : 0.0; /* only a stuck joint's indicator needs it */
    z[0] = friction_indicator(&f, MODE, x[S_v], F_A);
}

bool model_update_mode(Instance *inst, double t, double *x) {
    (void)t;
    if (friction_keeps_sliding(MODE, x[S_v])) return false;
    const Friction f = friction(inst);
    const double v = x[S_v];
    /* the force on a joint that stops or stands: at v = 0 (the back-EMF is then 0) */
    double at_rest[N_STATES];
    for (int j = 0; j < N_STATES; j++) at_rest[j] = x[j];
    at_rest[S_v] = 0.0;
    const int mode = friction_next_mode(&f, MODE, &x[S_v], active_force(inst, command_path(inst) ? at_rest : x));
    const bool changed = mode != MODE || v != x[S_v];
    MODE = mode;
    return changed;
}

void model_outputs(Instance *inst, double t, const double *x) {
    (void)t;
    const Friction f = friction(inst);
    const double F_A = active_force(inst, x);
    R(x) = x[S_x];
    R(v) = x[S_v];
    R(F_e) = x[S_F_e];
    R(der_F_e) = R(tau_e) > 0.0 ? (R(k_u) * R(u) - R(k_emf) * x[S_v] - x[S_F_e]) / R(tau_e) : 0.0;
    R(a) = acceleration(inst, &f, x[S_v], F_A);
    R(F_A) = F_A;
    R(F_F) = friction_force(&f, MODE, x[S_v], F_A);
    FLAG(stuck) = MODE == 0;
}

/* No time events: a continuous model. */
NO_TIME_EVENTS
