/* The friction law of the paper's model (docs/user-guide/model.md), shared by the cart and the
 * pendulum joint: viscous, Coulomb and stiction friction as a hybrid model with three modes,
 *   +1 sliding forward, 0 stuck, -1 sliding backward,
 * with optional extras (docs/user-guide/friction.md, "Friction law extras"; the Python twin of this law and each
 * joint's parameter names: pendfmu/friction.py), all off at their default 0:
 *
 * While sliding in direction d = mode:
 *     F_F = d (k_fw(d) |v| + F_K(d) + (F_S - F_K(d)) exp(-(v/v_S)^2)) + drag v |v|
 *     k_fw(d) = k_fw + d dk_fw,  F_K(d) = F_K + d dF_K   (direction-dependent terms)
 *     the exp term only when v_S > 0 (Stribeck: sliding friction falls from F_S to F_K)
 * While stuck:    v = 0 and the acceleration is exactly 0, so the friction holds the whole
 *                 net force F_N = F_A + F_O (F_O: constant offset force, e.g. cable drag);
 *                 this is the stiction min(F_S, |F_N|) sgn(F_N) of the paper whenever the
 *                 joint is allowed to stay stuck (|F_N| <= threshold).
 *
 * Breakaway threshold in direction d: a joint at rest moves only when d F_N exceeds
 * max(F_S, F_K(d)). With F_S >= F_K (the physical case) that is F_S, as in the paper's model. With
 * F_S < F_K a joint that broke away at F_S would decelerate at once (F_N - F_K < 0) and
 * stop again: it cannot move, and taking F_K as the threshold says so instead of chattering
 * at zero speed. Stribeck keeps this: at v -> 0 the sliding friction tends to F_S.
 *
 * Every function takes the active force F_A and adds the offset itself, so that the
 * offset changes the stick condition (|F_A + F_O| <= threshold) and nothing else.
 * With every extra at 0 each expression reduces to the plain law's bit for bit (x + 0.0
 * and x + d * 0.0 are x), which keeps the paper's model and earlier results identical.
 *
 * Event indicator, >= 0 while the mode is consistent:
 *   sliding: mode * v         (turns negative when the speed crosses zero)
 *   stuck:   threshold - |F_N| (turns negative when the net force overcomes stiction)
 */
#ifndef PENDFMU_FRICTION_H
#define PENDFMU_FRICTION_H

#include <math.h>
#include <stdbool.h>
#include <stdio.h>

typedef struct {
    double k_fw;  /* viscous coefficient */
    double F_K;   /* Coulomb (kinetic) friction */
    double F_S;   /* stiction */
    double dk_fw; /* direction asymmetry of k_fw: k_fw + d dk_fw in direction d */
    double dF_K;  /* direction asymmetry of F_K: F_K + d dF_K in direction d */
    double v_S;   /* Stribeck speed (0: no Stribeck effect) */
    double F_O;   /* constant offset force added to the active force */
    double drag;  /* quadratic drag coefficient: drag v |v| (the pendulum's air drag) */
} Friction;

static inline int sign_of(double value) { return value >= 0.0 ? 1 : -1; }

static inline double friction_coulomb(const Friction *f, int direction) { return f->F_K + direction * f->dF_K; }

static inline double friction_viscous(const Friction *f, int direction) { return f->k_fw + direction * f->dk_fw; }

/* The force a joint at rest can hold before it slides in `direction`. */
static inline double friction_threshold(const Friction *f, int direction) {
    return fmax(f->F_S, friction_coulomb(f, direction));
}

/* Whether a net force F_N leaves a joint at rest. */
static inline bool friction_holds(const Friction *f, double F_N) {
    return fabs(F_N) <= friction_threshold(f, sign_of(F_N));
}

/* The part of the sliding friction that is not the plain law's: Stribeck and drag. Zero
 * (and not evaluated) when they are off, so the plain law keeps its exact arithmetic. */
static inline double friction_extra(const Friction *f, int mode, double v) {
    double extra = 0.0;
    if (f->v_S > 0.0) {
        const double ratio = v / f->v_S;
        extra += mode * (f->F_S - friction_coulomb(f, mode)) * exp(-ratio * ratio);
    }
    if (f->drag != 0.0) extra += f->drag * v * fabs(v);
    return extra;
}

/* Friction force for the mode at speed v under active force F_A. */
static inline double friction_force(const Friction *f, int mode, double v, double F_A) {
    if (mode == 0) return F_A + f->F_O;
    const double plain = friction_viscous(f, mode) * v + friction_coulomb(f, mode) * mode;
    return f->v_S > 0.0 || f->drag != 0.0 ? plain + friction_extra(f, mode, v) : plain;
}

static inline double friction_indicator(const Friction *f, int mode, double v, double F_A) {
    if (mode != 0) return mode * v;
    const double F_N = F_A + f->F_O;
    return friction_threshold(f, sign_of(F_N)) - fabs(F_N);
}

/* The mode of a joint at rest under active force F_A: stuck, or sliding the way the net
 * force pushes. */
static inline int friction_mode_at_rest(const Friction *f, double F_A) {
    const double F_N = F_A + f->F_O;
    return friction_holds(f, F_N) ? 0 : sign_of(F_N);
}

/* The mode a joint starts in, from its initial speed and active force. */
static inline int friction_initial_mode(const Friction *f, double v, double F_A) {
    return v != 0.0 ? sign_of(v) : friction_mode_at_rest(f, F_A);
}

/* Whether a sliding joint simply goes on sliding: then no event can change its mode, and
 * the active force (trigonometry, for the pendulum) need not be evaluated. */
static inline bool friction_keeps_sliding(int mode, double v) { return mode * v > 0.0; }

/* Mode after an event. A sliding joint whose speed reached zero sticks, or reverses if
 * the net force exceeds the threshold; a stuck joint breaks away in the direction of
 * F_A + F_O. *v is set to exactly 0 whenever the joint stops. */
static inline int friction_next_mode(const Friction *f, int mode, double *v, double F_A) {
    if (mode != 0) {
        if (mode * *v > 0.0) return mode;
        *v = 0.0;
    }
    return friction_mode_at_rest(f, F_A);
}

/* Whether a direction asymmetry leaves both directions' term >= 0 (|asym| <= mean); if not,
 * writes why into `why`, naming both parameters. An asymmetry may tilt the law, but a
 * friction term must not turn into a drive. */
static inline bool friction_asymmetry_ok(double mean, double asym, const char *mean_name, const char *asym_name,
                                         const char *unit, char *why, size_t size) {
    if (fabs(asym) <= mean) return true;
    snprintf(why, size, "|%s| = %g %s exceeds %s = %g %s: %s +- %s of one direction would be negative", asym_name,
             fabs(asym), unit, mean_name, mean, unit, mean_name, asym_name);
    return false;
}

#endif
