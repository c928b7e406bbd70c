/* Cart: the cart on the lead screw, driven by the motor (paper Eq. 2-5, MODEL.md):
 *
 *     (m_c + m_p) a = F_A - F_F
 *     F_A = eta k_M k_D I + A(eta) m_p l (w^2 sin(phi) - alpha cos(phi))
 *     A(eta) = max(0, (2 eta - 1) / eta)
 *
 * A self-locking screw (eta <= 0.5) ignores the pendulum inputs; a back-drivable one
 * couples cart and pendulum accelerations (an algebraic loop the master solves).
 * F_F is the three-mode stick-slip friction of friction.h.
 */
#include <math.h>
#include <stdio.h>

#include "framework.h"
#include "friction.h"

static Friction friction(const Instance *inst) {
    const Friction f = {R(k_fwc), R(F_Kc), R(F_Sc)};
    return f;
}

static double active_force(const Instance *inst) {
    const double eta = R(eta);
    const double drive = eta * R(k_M) * R(k_D) * R(I);
    if (eta <= 0.5) return drive; /* self-locking: the pendulum cannot push the cart */
    const double back_drive = (2.0 * eta - 1.0) / eta;
    return drive + back_drive * R(m_p) * R(l) * (R(w) * R(w) * sin(R(phi)) - R(alpha) * cos(R(phi)));
}

bool model_check_parameters(const Instance *inst, char *why, size_t size) {
    (void)inst, (void)why, (void)size;
    return true;
}

void model_initial_states(Instance *inst) {
    const Friction f = friction(inst);
    inst->s.x[S_x] = R(x0);
    inst->s.x[S_v] = R(v0);
    MODE = friction_initial_mode(&f, R(v0), active_force(inst));
}

double model_max_step(const Instance *inst) {
    /* RK4 is stable up to 2.78 time constants; stay well inside for accuracy. */
    return R(k_fwc) > 0.0 ? 0.2 * (R(m_c) + R(m_p)) / R(k_fwc) : INFINITY;
}

bool model_exact_step(Instance *inst, double t, const double *x, double h, double *x_out) {
    (void)inst, (void)t, (void)x, (void)h, (void)x_out;
    return false; /* no closed form: RK4 */
}

void model_derivatives(const Instance *inst, double t, const double *x, double *dx) {
    (void)t;
    const Friction f = friction(inst);
    const double F_A = active_force(inst);
    dx[S_x] = x[S_v];
    dx[S_v] = MODE == 0 ? 0.0 : (F_A - friction_force(&f, MODE, x[S_v], F_A)) / (R(m_c) + R(m_p));
}

void model_event_indicators(const Instance *inst, double t, const double *x, double *z) {
    (void)t;
    const Friction f = friction(inst);
    z[0] = friction_indicator(&f, MODE, x[S_v], active_force(inst));
}

bool model_update_mode(Instance *inst, double t, double *x) {
    (void)t;
    const Friction f = friction(inst);
    const double v = x[S_v];
    const int mode = friction_next_mode(&f, MODE, &x[S_v], active_force(inst));
    const bool changed = mode != MODE || v != x[S_v];
    MODE = mode;
    return changed;
}

void model_outputs(Instance *inst, double t, const double *x) {
    const Friction f = friction(inst);
    double dx[N_STATES];
    model_derivatives(inst, t, x, dx);
    const double F_A = active_force(inst);
    R(x) = x[S_x];
    R(v) = x[S_v];
    R(a) = dx[S_v];
    R(F_A) = F_A;
    R(F_F) = friction_force(&f, MODE, x[S_v], F_A);
    FLAG(stuck) = MODE == 0;
}
