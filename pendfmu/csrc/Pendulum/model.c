/* Pendulum: the pendulum on the cart's pivot (paper Eq. 6-8, docs/user-guide/model.md),
 * phi from the upward vertical:
 *
 *     J_p alpha = T_A - T_F,    T_A = m_p l (g sin(phi) - a cos(phi))
 *
 * J_p = 0 selects the uniform rod of the paper, J_p = (4/3) m_p l^2. T_F is the
 * three-mode stick-slip friction of friction.h, with its optional extras (Stribeck speed
 * w_Sp, asymmetries dk_fwp and dT_Kp, offset torque T_Op, quadratic air drag k_dp w|w|;
 * all 0 by default).
 */
#include <math.h>
#include <stdio.h>

#include "framework.h"
#include "friction.h"
#include "trig_memo.h"

static Friction friction(const Instance *inst) {
    const Friction f = {R(k_fwp), R(T_Kp), R(T_Sp), R(dk_fwp), R(dT_Kp), R(w_Sp), R(T_Op), R(k_dp)};
    return f;
}

static double inertia(const Instance *inst) {
    return R(J_p) > 0.0 ? R(J_p) : 4.0 / 3.0 * R(m_p) * R(l) * R(l);
}

/* The equation of motion divided by J, for the RK4 stages:
 *     alpha = GRAVITY sin phi - ARM a cos phi - VISCOUS(d) w - COULOMB(d) mode [+ extras]
 * with GRAVITY = m l g / J, ARM = m l / J, VISCOUS(d) = (k_fwp + d dk_fwp) / J,
 * COULOMB(d) = (T_Kp + d dT_Kp) / J for the direction d = mode (the _BACK slot follows the
 * _FWD one). EXTRAS flags the terms that need more work per stage (offset, Stribeck, drag):
 * without them the stages compute exactly what they did before the extras existed. */
enum { D_GRAVITY, D_ARM, D_VISCOUS_FWD, D_VISCOUS_BACK, D_COULOMB_FWD, D_COULOMB_BACK, D_EXTRAS, D_INERTIA };

static void derive_constants(Instance *inst) {
    double *d = inst->s.derived;
    const double J = inertia(inst);
    d[D_GRAVITY] = R(m_p) * R(l) * R(g) / J;
    d[D_ARM] = R(m_p) * R(l) / J;
    d[D_VISCOUS_FWD] = (R(k_fwp) + R(dk_fwp)) / J;
    d[D_VISCOUS_BACK] = (R(k_fwp) - R(dk_fwp)) / J;
    d[D_COULOMB_FWD] = (R(T_Kp) + R(dT_Kp)) / J;
    d[D_COULOMB_BACK] = (R(T_Kp) - R(dT_Kp)) / J;
    d[D_EXTRAS] = R(T_Op) != 0.0 || R(w_Sp) > 0.0 || R(k_dp) != 0.0;
    d[D_INERTIA] = J;
}

static double active_torque(const Instance *inst, const double *x) {
    const double m_l = R(m_p) * R(l);
    return trig_memo_wave(inst, 0, x[S_phi], m_l * R(g), -m_l * R(a)); /* m l (g sin phi - a cos phi) */
}

bool model_check_parameters(const Instance *inst, char *why, size_t size) {
    if (!friction_asymmetry_ok(R(k_fwp), R(dk_fwp), "k_fwp", "dk_fwp", "N.m.s", why, size) ||
        !friction_asymmetry_ok(R(T_Kp), R(dT_Kp), "T_Kp", "dT_Kp", "N.m", why, size))
        return false;
    const double point_mass = R(m_p) * R(l) * R(l);
    if (R(J_p) > 0.0 && R(J_p) < point_mass * (1.0 - 1e-12)) {
        snprintf(why, size,
                 "J_p = %g kg.m2 is below m_p*l^2 = %g kg.m2, the inertia of the mass m_p concentrated at "
                 "distance l; a body about its pivot has at least that (set J_p = 0 for a uniform rod)",
                 R(J_p), point_mass);
        return false;
    }
    return true;
}

void model_initial_states(Instance *inst) {
    const Friction f = friction(inst);
    inst->s.x[S_phi] = R(phi0);
    inst->s.x[S_w] = R(w0);
    derive_constants(inst);
    MODE = friction_initial_mode(&f, R(w0), active_torque(inst, inst->s.x));
}

double model_max_step(const Instance *inst) {
    const double J = inertia(inst);
    const double omega = sqrt(R(m_p) * R(l) * R(g) / J); /* small-angle natural frequency */
    double h = omega > 0.0 ? 0.05 / omega : INFINITY;
    /* The sliding law's steepest rate |dT_F/dw|: the larger viscous coefficient plus the
     * Stribeck slope's maximum |T_S - T_K| sqrt(2/e) / w_S. The drag's rate 2 k_dp |w| is
     * not bounded here: for air drag it is far below the viscous one. */
    double stiffness = R(k_fwp) + fabs(R(dk_fwp));
    if (R(w_Sp) > 0.0) stiffness += (fabs(R(T_Sp) - R(T_Kp)) + fabs(R(dT_Kp))) * sqrt(2.0 / exp(1.0)) / R(w_Sp);
    if (stiffness > 0.0) h = fmin(h, 0.2 * J / stiffness);
    return h;
}

bool model_exact_step(Instance *inst, double t, const double *x, double h, double *x_out) {
    (void)inst, (void)t, (void)x, (void)h, (void)x_out;
    return false; /* no closed form: RK4 */
}

void model_derivatives(const Instance *inst, double t, const double *x, double *dx) {
    (void)t;
    const double *d = inst->s.derived;
    dx[S_phi] = x[S_w];
    if (MODE == 0) {
        dx[S_w] = 0.0; /* stuck */
        return;
    }
    /* (T_A - T_F) / J with the sliding friction law T_F = k_fwp(d) w + T_Kp(d) mode */
    const int back = MODE < 0;
    dx[S_w] = trig_memo_wave(inst, 0, x[S_phi], d[D_GRAVITY], -d[D_ARM] * R(a)) - d[D_VISCOUS_FWD + back] * x[S_w] -
              d[D_COULOMB_FWD + back] * MODE;
    if (d[D_EXTRAS] != 0.0) { /* + (T_Op - Stribeck - drag) / J */
        const Friction f = friction(inst);
        dx[S_w] += (R(T_Op) - friction_extra(&f, MODE, x[S_w])) / d[D_INERTIA];
    }
}

void model_event_indicators(const Instance *inst, double t, const double *x, double *z) {
    (void)t;
    const Friction f = friction(inst);
    const double T_A = MODE == 0 ? active_torque(inst, x) : 0.0; /* only a stuck joint's indicator needs it */
    z[0] = friction_indicator(&f, MODE, x[S_w], T_A);
}

bool model_update_mode(Instance *inst, double t, double *x) {
    (void)t;
    if (friction_keeps_sliding(MODE, x[S_w])) return false;
    const Friction f = friction(inst);
    const double w = x[S_w];
    const int mode = friction_next_mode(&f, MODE, &x[S_w], active_torque(inst, x));
    const bool changed = mode != MODE || w != x[S_w];
    MODE = mode;
    return changed;
}

void model_outputs(Instance *inst, double t, const double *x) {
    const Friction f = friction(inst);
    const double T_A = active_torque(inst, x);
    const double T_F = friction_force(&f, MODE, x[S_w], T_A);
    double dx[N_STATES];
    model_derivatives(inst, t, x, dx); /* alpha exactly as the integrator sees it */
    R(phi) = x[S_phi];
    R(w) = x[S_w];
    R(alpha) = dx[S_w];
    R(T_A) = T_A;
    R(T_F) = T_F;
    FLAG(stuck) = MODE == 0;
}

/* No time events: a continuous model. */
NO_TIME_EVENTS
