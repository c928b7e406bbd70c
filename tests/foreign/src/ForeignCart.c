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
   also when F_s < F_c. */

#include <math.h>

#include "foreign.h"

enum { VR_U = 1, VR_X = 2, VR_V = 3, VR_M = 10, VR_K_U, VR_C_V, VR_F_C, VR_F_S, VR_V_S, VR_F_0, VR_X0, VR_V0, VR_H_MAX };
enum { VR_MODE = 1 };

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

static double active_force(const Instance *c) { return R(VR_K_U) * R(VR_U) + R(VR_F_0); }

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
        left -= hi;
    }
    /* Only reached when |F_A| exceeds F_s by a rounding error and the start-up cannot
       leave zero: the cart stays where it is. */
    if (left > 0.0)
        R(VR_V) = 0.0;
}

static fmi2Status initialize(Instance *c) {
    R(VR_X) = R(VR_X0);
    R(VR_V) = R(VR_V0);
    MODE = mode_at(c, active_force(c));
    return fmi2OK;
}

/* Substeps no longer than h_max, nor than the viscous time constant m/c_v (RK4 would be
   inaccurate, then unstable, beyond it), dividing the step evenly. */
static fmi2Status do_step(Instance *c, double h) {
    double force = active_force(c);
    double longest = R(VR_H_MAX);
    if (R(VR_C_V) * longest > R(VR_M))
        longest = R(VR_M) / R(VR_C_V);
    double n = ceil(h / longest - 1e-9);
    if (n < 1.0)
        n = 1.0;
    if (n > 1e9)
        return fail(c, "fmi2DoStep: a step of %g s would take %g internal steps of %g s", h, n, longest);
    double dt = h / n;
    for (long k = 0; k < (long)n; k++) {
        substep(c, force, dt);
        if (MODE == 0 && R(VR_V) == 0.0)
            break; /* stuck for the rest of the step */
    }
    MODE = mode_at(c, force);
    if (!isfinite(R(VR_X)) || !isfinite(R(VR_V)))
        return fail(c, "fmi2DoStep: the solution is not finite at t = %g (x = %g, v = %g); reduce h_max",
                    c->d.time + h, R(VR_X), R(VR_V));
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
