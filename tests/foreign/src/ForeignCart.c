/* ForeignCart: a cart driven by a voltage, with viscous, Coulomb and Stribeck stiction
   friction and exact stick-slip, as a Co-Simulation FMU "from another tool".

       m a = k_u u + F_0 - F_f
       sliding in direction s = +-1:  F_f = c_v v + s (F_c + (F_s - F_c) exp(-(v/v_s)^2))
       stuck (v = 0, a = 0) while |k_u u + F_0| <= F_s

   Method (deliberately not pendfmu's): the input is held over a communication step, so the
   active force F_A = k_u u + F_0 is constant inside it. A stuck cart therefore breaks away
   only at the start of a step (or at a stop inside it, where it reverses), and a stuck
   cart stays stuck for the whole step. A sliding cart is integrated with classic RK4 on
   equal substeps no longer than h_max (nor than the viscous time constant m/c_v); the sliding equation for direction s is continued
   past v = 0, so when a substep ends with s v <= 0 the stop is located by bisection on the
   length of a single RK4 step from the substep's start (to 1e-13 s), v is set to exactly
   0 there and the mode is chosen again. At v = 0 the sliding friction equals F_s for any
   v_s, so a breakaway (|F_A| > F_s) always accelerates away from zero: no chattering,
   also when F_s < F_c.

   Planted bugs, one per build (tests/foreign/mutants.py compiles each with -D<NAME>; none is
   defined for the correct FMU), for testing `pendfmu check` on an FMU it did not make:
     MUTANT_EVENTS_AT_POINTS  stick/slip decided only at communication points: a step slides in
                              the direction it started with, past v = 0, and a cart that passed
                              zero is stopped at the end of the step (no event location)
     MUTANT_FORGET_MODE       the mode is kept as a discrete state (the sliding direction is
                              taken from it), and fmi2SetFMUstate restores everything but it
                              (foreign_fmi2.c)
     MUTANT_NAN_ABOVE_11V     above 11 V of input the outputs turn NaN and every call still
                              returns OK (a motor map that ends at 11 V, no finiteness check)
     MUTANT_STEP_JUMP         the position output leads the state by the last communication
                              step (x + h v), so it jumps with the step size
   (MUTANT_RESET_KEEPS_PARAMETERS, fmi2Reset keeping the parameters, is in foreign_fmi2.c.) */

#include <math.h>

#include "foreign.h"

enum { VR_U = 1, VR_X = 2, VR_V = 3, VR_M = 10, VR_K_U, VR_C_V, VR_F_C, VR_F_S, VR_V_S, VR_F_0, VR_X0, VR_V0, VR_H_MAX };
enum { VR_MODE = 1 };
enum { VR_X_STATE = 20 }; /* MUTANT_STEP_JUMP: the position state behind the leading output */

static const RealVariable REALS[] = {
    {VR_U, "u", INPUT, 0.0, -INFINITY, INFINITY, 0, "the voltage"},
    {VR_X, "x", OUTPUT, 0.0, -INFINITY, INFINITY, 0, "the position"},
    {VR_V, "v", OUTPUT, 0.0, -INFINITY, INFINITY, 0, "the speed"},
    {VR_M, "m", PARAMETER, 1.0, 0.0, INFINITY, 1, "a mass"},
    {VR_K_U, "k_u", PARAMETER, 1.0, -INFINITY, INFINITY, 0, "the force gain"},
    {VR_C_V, "c_v", PARAMETER, 1.0, 0.0, INFINITY, 0, "a viscous coefficient"},
    {VR_F_C, "F_c", PARAMETER, 0.5, 0.0, INFINITY, 0, "a Coulomb force"},
    {VR_F_S, "F_s", PARAMETER, 0.8, 0.0, INFINITY, 0, "a stiction force"},
    {VR_V_S, "v_s", PARAMETER, 0.01, 0.0, INFINITY, 1, "the Stribeck velocity"},
    {VR_F_0, "F_0", PARAMETER, 0.0, -INFINITY, INFINITY, 0, "the offset force"},
    {VR_X0, "x0", PARAMETER, 0.0, -INFINITY, INFINITY, 0, "the initial position"},
    {VR_V0, "v0", PARAMETER, 0.0, -INFINITY, INFINITY, 0, "the initial speed"},
    {VR_H_MAX, "h_max", PARAMETER, 1e-3, 0.0, 1.0, 1, "the internal step"},
};

static const IntegerVariable INTEGERS[] = {{VR_MODE, "mode", 0}};

#define R(vr) (c->d.r[vr])
#define MODE (c->d.i[VR_MODE])

static double active_force(const Instance *c) {
#ifdef MUTANT_NAN_ABOVE_11V
    if (R(VR_U) > 11.0)
        return NAN;
#endif
    return R(VR_K_U) * R(VR_U) + R(VR_F_0);
}

/* Acceleration while sliding in direction s, for any v (continued past v = 0). */
static double sliding_acceleration(const Instance *c, double force, int s, double v) {
    double q = v / R(VR_V_S);
    double friction = R(VR_C_V) * v + s * (R(VR_F_C) + (R(VR_F_S) - R(VR_F_C)) * exp(-q * q));
    return (force - friction) / R(VR_M);
}

/* One classic RK4 step of x' = v, v' = a(v) (a does not depend on x). */
static void rk4(const Instance *c, double force, int s, double h, double x, double v, double *x1, double *v1) {
    double a1 = sliding_acceleration(c, force, s, v);
    double w2 = v + 0.5 * h * a1, a2 = sliding_acceleration(c, force, s, w2);
    double w3 = v + 0.5 * h * a2, a3 = sliding_acceleration(c, force, s, w3);
    double w4 = v + h * a3, a4 = sliding_acceleration(c, force, s, w4);
    *v1 = v + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
    *x1 = x + h / 6.0 * (v + 2.0 * w2 + 2.0 * w3 + w4);
}

/* The mode for the current speed: sliding while v != 0; at v = 0 stuck unless the active
   force exceeds the stiction force (then sliding in its direction). */
static int mode_at(const Instance *c, double force) {
#ifdef MUTANT_FORGET_MODE
    if (MODE != 0)
        return MODE; /* sliding until a stop sets the mode to 0 */
#endif
    double v = R(VR_V);
    if (v != 0.0)
        return v > 0.0 ? 1 : -1;
    if (fabs(force) > R(VR_F_S))
        return force > 0.0 ? 1 : -1;
    return 0;
}

/* Advances by one substep h with constant force, handling stops inside it. */
static void substep(Instance *c, double force, double h) {
    double left = h;
    for (int events = 0; left > 0.0 && events < 8; events++) {
        MODE = mode_at(c, force);
        if (MODE == 0)
            return; /* stuck: F_A is constant for the rest of the step */
        int s = MODE;
        double x = R(VR_X), v = R(VR_V), x1, v1;
        rk4(c, force, s, left, x, v, &x1, &v1);
        if (s * v1 > 0.0) {
            R(VR_X) = x1;
            R(VR_V) = v1;
            return;
        }
        /* The speed reached zero inside: bisect on the RK4 step length. */
        double lo = 0.0, hi = left;
        while (hi - lo > 1e-13) {
            double mid = 0.5 * (lo + hi);
            rk4(c, force, s, mid, x, v, &x1, &v1);
            if (s * v1 > 0.0)
                lo = mid;
            else
                hi = mid;
        }
        rk4(c, force, s, hi, x, v, &x1, &v1);
        R(VR_X) = x1;
        R(VR_V) = 0.0;
        MODE = 0; /* stopped: the mode is chosen again */
        left -= hi;
    }
    /* Only reached when |F_A| exceeds F_s by a rounding error and the start-up cannot
       leave zero: the cart stays where it is. */
    if (left > 0.0) {
        R(VR_V) = 0.0;
        MODE = 0;
    }
}

#ifdef MUTANT_EVENTS_AT_POINTS
/* The planted bug: the whole step slides in the direction of its start, continued past
   v = 0; a cart that passed zero is stopped at the communication point. */
static void slide_without_stops(Instance *c, double force, double dt, long n) {
    int s = MODE;
    for (long k = 0; k < n && s != 0; k++) {
        double x1, v1;
        rk4(c, force, s, dt, R(VR_X), R(VR_V), &x1, &v1);
        R(VR_X) = x1;
        R(VR_V) = v1;
    }
    if (s * R(VR_V) < 0.0)
        R(VR_V) = 0.0;
}
#endif

static fmi2Status initialize(Instance *c) {
    R(VR_X) = R(VR_X0);
    R(VR_V) = R(VR_V0);
    R(VR_X_STATE) = R(VR_X0);
    MODE = 0;
    MODE = mode_at(c, active_force(c));
    return fmi2OK;
}

/* Substeps no longer than h_max, nor than the viscous time constant m/c_v (RK4 would be
   inaccurate, then unstable, beyond it), dividing the step evenly. */
static fmi2Status do_step(Instance *c, double h) {
    double force = active_force(c);
#ifdef MUTANT_NAN_ABOVE_11V
    if (isnan(force)) { /* the NaN reaches the outputs, and no check follows */
        R(VR_X) = NAN;
        R(VR_V) = NAN;
        return fmi2OK;
    }
#endif
    double longest = R(VR_H_MAX);
    if (R(VR_C_V) * longest > R(VR_M))
        longest = R(VR_M) / R(VR_C_V);
    double n = ceil(h / longest - 1e-9);
    if (n < 1.0)
        n = 1.0;
    if (n > 1e9)
        return fail(c, "fmi2DoStep: a step of %g s would take %g internal steps of %g s", h, n, longest);
    double dt = h / n;
#ifdef MUTANT_STEP_JUMP
    R(VR_X) = R(VR_X_STATE);
#endif
#ifdef MUTANT_EVENTS_AT_POINTS
    (void)substep; /* the correct stepping, replaced */
    MODE = mode_at(c, force);
    slide_without_stops(c, force, dt, (long)n);
#else
    for (long k = 0; k < (long)n; k++) {
        substep(c, force, dt);
        if (MODE == 0 && R(VR_V) == 0.0)
            break; /* stuck for the rest of the step */
    }
#endif
    MODE = mode_at(c, force);
#ifdef MUTANT_STEP_JUMP
    R(VR_X_STATE) = R(VR_X);
    R(VR_X) += h * R(VR_V);
#endif
#ifndef MUTANT_NAN_ABOVE_11V
    if (!isfinite(R(VR_X)) || !isfinite(R(VR_V)))
        return fail(c, "fmi2DoStep: the solution is not finite at t = %g (x = %g, v = %g); reduce h_max",
                    c->d.time + h, R(VR_X), R(VR_V));
#endif
    return fmi2OK;
}

const Model MODEL = {
    .name = "ForeignCart",
    .guid = "{6a1f0c52-13e0-4c6b-9d1e-f0a1e5c0a713}",
    .reals = REALS,
    .n_reals = sizeof REALS / sizeof REALS[0],
    .integers = INTEGERS,
    .n_integers = 1,
    .can_get_set_state = 1,
    .can_reset = 1,
    .initialize = initialize,
    .do_step = do_step,
};
