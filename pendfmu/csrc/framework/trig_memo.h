/* p sin(phi) + q cos(phi) for an angle that moves little between calls, as the pendulum's
 * angle does between the stages of its RK4 steps (well under a milliradian apart).
 *
 * libm's sin and cos cost about 20 ns and were the largest single cost of a Co-Simulation
 * step. The memo keeps one reference angle a with sin(a) and cos(a) from libm; an angle
 * a + d with |d| < TRIG_MEMO_REACH is then evaluated by the angle-addition formulas with
 * the Taylor series of sin d (to d^7) and cos d (to d^6). The first omitted terms are
 * below 3e-18 relative to the kept ones, so the result is exact to a few rounding errors.
 * A farther angle is evaluated by libm and becomes the new reference.
 *
 * The memo (TRIG_MEMO_SLOTS doubles of DynamicState.memo) lives in the FMU state, so the
 * sequence of references is part of what fmi2GetFMUstate saves, and restored runs repeat
 * to the bit.
 */
#ifndef PENDFMU_TRIG_MEMO_H
#define PENDFMU_TRIG_MEMO_H

#include <math.h>

#include "framework.h"

#define TRIG_MEMO_REACH 1e-2

enum { MEMO_VALID, MEMO_ANGLE, MEMO_SIN, MEMO_COS, TRIG_MEMO_SLOTS };

/* p sin(angle) + q cos(angle) through the memo at inst->s.memo + slot. Near the reference
 * a, with S = sin a and C = cos a,
 *     p sin(a + d) + q cos(a + d) = cos d (p S + q C) + sin d (p C - q S),
 * whose brackets do not depend on the angle: the chain of dependent operations from one
 * RK4 stage to the next is only d, the two short series, and one multiply-add.
 * The memo is logically const: a cache of a pure function, written through the const
 * Instance that model_derivatives receives. */
static inline double trig_memo_wave(const Instance *inst, int slot, double angle, double p, double q) {
    double *memo = (double *)inst->s.memo + slot;
    const double d = angle - memo[MEMO_ANGLE];
    if (memo[MEMO_VALID] != 0.0 && fabs(d) < TRIG_MEMO_REACH) {
        const double d2 = d * d;
        /* Horner with the reciprocals folded at compile time (a division costs ~15 cycles) */
        const double sin_d = d * (1.0 - d2 * (1.0 / 6.0) * (1.0 - d2 * (1.0 / 20.0) * (1.0 - d2 * (1.0 / 42.0))));
        const double cos_d = 1.0 - d2 * 0.5 * (1.0 - d2 * (1.0 / 12.0) * (1.0 - d2 * (1.0 / 30.0)));
        const double S = memo[MEMO_SIN], C = memo[MEMO_COS];
        return cos_d * (p * S + q * C) + sin_d * (p * C - q * S);
    }
    memo[MEMO_VALID] = 1.0;
    memo[MEMO_ANGLE] = angle;
    memo[MEMO_SIN] = sin(angle);
    memo[MEMO_COS] = cos(angle);
    return p * memo[MEMO_SIN] + q * memo[MEMO_COS];
}

#endif
