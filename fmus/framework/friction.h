/* The friction law of MODEL.md, shared by the cart and the pendulum joint: viscous,
 * Coulomb and stiction friction as a hybrid model with three modes,
 *   +1 sliding forward, 0 stuck, -1 sliding backward.
 *
 * While sliding:  F_F = k_fw v + F_K sgn(v)
 * While stuck:    v = 0 and the acceleration is exactly 0, so the friction holds the whole
 *                 active force F_A; this is the stiction min(F_S, |F_A|) sgn(F_A) of the
 *                 paper whenever the joint is allowed to stay stuck (|F_A| <= F_S).
 *
 * Breakaway threshold: a joint at rest moves only when |F_A| exceeds max(F_S, F_K). With
 * F_S >= F_K (the physical case) that is F_S, as in MODEL.md. With F_S < F_K a joint that
 * broke away at F_S would decelerate at once (F_A - F_K < 0) and stop again: it cannot
 * move, and taking F_K as the threshold says so instead of chattering at zero speed.
 *
 * Event indicator, >= 0 while the mode is consistent:
 *   sliding: mode * v         (turns negative when the speed crosses zero)
 *   stuck:   threshold - |F_A| (turns negative when the active force overcomes stiction)
 */
#ifndef PENDFMU_FRICTION_H
#define PENDFMU_FRICTION_H

#include <math.h>
#include <stdbool.h>

typedef struct {
    double k_fw; /* viscous coefficient */
    double F_K;  /* Coulomb (kinetic) friction */
    double F_S;  /* stiction */
} Friction;

static inline double friction_threshold(const Friction *f) { return fmax(f->F_S, f->F_K); }

static inline int sign_of(double value) { return value >= 0.0 ? 1 : -1; }

/* Friction force for the mode at speed v under active force F_A. */
static inline double friction_force(const Friction *f, int mode, double v, double F_A) {
    return mode == 0 ? F_A : f->k_fw * v + f->F_K * mode;
}

static inline double friction_indicator(const Friction *f, int mode, double v, double F_A) {
    return mode == 0 ? friction_threshold(f) - fabs(F_A) : mode * v;
}

/* The mode a joint starts in, from its initial speed and active force. */
static inline int friction_initial_mode(const Friction *f, double v, double F_A) {
    if (v != 0.0) return sign_of(v);
    return fabs(F_A) <= friction_threshold(f) ? 0 : sign_of(F_A);
}

/* Whether a sliding joint simply goes on sliding: then no event can change its mode, and
 * the active force (trigonometry, for the pendulum) need not be evaluated. */
static inline bool friction_keeps_sliding(int mode, double v) { return mode * v > 0.0; }

/* Mode after an event. A sliding joint whose speed reached zero sticks, or reverses if
 * the active force exceeds the threshold; a stuck joint breaks away in the direction of
 * F_A. *v is set to exactly 0 whenever the joint stops. */
static inline int friction_next_mode(const Friction *f, int mode, double *v, double F_A) {
    if (mode != 0) {
        if (mode * *v > 0.0) return mode;
        *v = 0.0;
    }
    return fabs(F_A) <= friction_threshold(f) ? 0 : sign_of(F_A);
}

#endif
