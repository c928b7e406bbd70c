/* sin and cos of an angle that moves little between calls, as the pendulum's angle does
 * between the stages of its RK4 steps (well under a milliradian apart).
 *
 * libm's sin and cos cost about 20 ns and are the largest single cost of a Co-Simulation
 * step. The memo keeps one reference angle a with sin(a) and cos(a) from libm; an angle
 * a + d with |d| < TRIG_MEMO_REACH is then evaluated by the angle-addition formula,
 *     sin(a + d) = sin a cos d + cos a sin d,   cos(a + d) = cos a cos d - sin a sin d,
 * with the Taylor series of sin d (to d^7) and cos d (to d^6). The first omitted terms
 * are below 3e-18 relative to the kept ones, so the result is exact to a few rounding
 * errors. A farther angle is evaluated by libm and becomes the new reference.
 *
 * The memo lives in the FMU state (DynamicState.memo), so the sequence of references is
 * part of what fmi2GetFMUstate saves, and restored runs repeat to the bit.
 */
#ifndef PENDFMU_TRIG_MEMO_H
#define PENDFMU_TRIG_MEMO_H

#include <math.h>

#include "framework.h"

#define TRIG_MEMO_REACH 1e-2

enum { MEMO_VALID, MEMO_ANGLE, MEMO_SIN, MEMO_COS };

/* The memo is logically const: a cache of a pure function, written through a const
 * Instance as model_derivatives receives it. */
static inline void trig_memo_sin_cos(const Instance *inst, double angle, double *sine, double *cosine) {
    double *memo = (double *)inst->s.memo;
    const double d = angle - memo[MEMO_ANGLE];
    if (memo[MEMO_VALID] != 0.0 && fabs(d) < TRIG_MEMO_REACH) {
        const double d2 = d * d;
        /* Horner with the reciprocals folded at compile time (a division costs ~15 cycles) */
        const double sin_d = d * (1.0 - d2 * (1.0 / 6.0) * (1.0 - d2 * (1.0 / 20.0) * (1.0 - d2 * (1.0 / 42.0))));
        const double cos_d = 1.0 - d2 * 0.5 * (1.0 - d2 * (1.0 / 12.0) * (1.0 - d2 * (1.0 / 30.0)));
        *sine = memo[MEMO_SIN] * cos_d + memo[MEMO_COS] * sin_d;
        *cosine = memo[MEMO_COS] * cos_d - memo[MEMO_SIN] * sin_d;
        return;
    }
    memo[MEMO_VALID] = 1.0;
    memo[MEMO_ANGLE] = angle;
    memo[MEMO_SIN] = *sine = sin(angle);
    memo[MEMO_COS] = *cosine = cos(angle);
}

#endif
