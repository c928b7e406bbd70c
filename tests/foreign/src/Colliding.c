/* Colliding: a Co-Simulation FMU whose variable names are pendfmu's own (eta, m_p, k_fwc,
   I, x, v, F_A) with other meanings and other value references, so that a host which maps
   names to pendfmu's components, or value references by name, is caught out.

   A mass m_p driven by a current I through a force constant k_F and an efficiency eta,
   with viscous friction k_fwc only:

       F_A = eta k_F I            (an output with direct feedthrough from I)
       m_p v' = F_A - k_fwc v,    x' = v

   The step is exact for an input held over it (with k_fwc = 0 as a limit). */

#include <math.h>

#include "foreign.h"

/* Value references on purpose unlike pendfmu's Cart and overlapping ForeignCart's. */
enum { VR_ETA = 1, VR_M_P = 2, VR_K_FWC = 3, VR_K_F = 4, VR_X0 = 5, VR_V0 = 6, VR_I = 10, VR_X = 11, VR_V = 12, VR_F_A = 13 };

static const RealVariable REALS[] = {
    {VR_ETA, "eta", PARAMETER, 0.9, 0.0, 1.0, 1, "an efficiency"},
    {VR_M_P, "m_p", PARAMETER, 1.0, 0.0, INFINITY, 1, "a mass"},
    {VR_K_FWC, "k_fwc", PARAMETER, 1.0, 0.0, INFINITY, 0, "a viscous coefficient"},
    {VR_K_F, "k_F", PARAMETER, 1.0, -INFINITY, INFINITY, 0, "the force constant"},
    {VR_X0, "x0", PARAMETER, 0.0, -INFINITY, INFINITY, 0, "the initial position"},
    {VR_V0, "v0", PARAMETER, 0.0, -INFINITY, INFINITY, 0, "the initial speed"},
    {VR_I, "I", INPUT, 0.0, -INFINITY, INFINITY, 0, "the current"},
    {VR_X, "x", OUTPUT, 0.0, -INFINITY, INFINITY, 0, "the position"},
    {VR_V, "v", OUTPUT, 0.0, -INFINITY, INFINITY, 0, "the speed"},
    {VR_F_A, "F_A", OUTPUT, 0.0, -INFINITY, INFINITY, 0, "the drive force"},
};

#define R(vr) (c->d.r[vr])

static void update(Instance *c) { R(VR_F_A) = R(VR_ETA) * R(VR_K_F) * R(VR_I); }

static fmi2Status initialize(Instance *c) {
    R(VR_X) = R(VR_X0);
    R(VR_V) = R(VR_V0);
    update(c);
    return fmi2OK;
}

/* With z = lambda h: phi1 = (1 - e^-z)/lambda and phi2 = (h - phi1)/lambda, so that
   v(h) = v e^-z + a phi1 and x(h) = x + v phi1 + a phi2 (a = F_A/m_p); series for small z. */
static fmi2Status do_step(Instance *c, double h) {
    update(c);
    double lambda = R(VR_K_FWC) / R(VR_M_P), a = R(VR_F_A) / R(VR_M_P), z = lambda * h;
    double phi1, phi2;
    if (z < 1e-3) {
        phi1 = h * (1.0 - z / 2.0 + z * z / 6.0 - z * z * z / 24.0);
        phi2 = h * h * (0.5 - z / 6.0 + z * z / 24.0 - z * z * z / 120.0);
    } else {
        phi1 = -expm1(-z) / lambda;
        phi2 = (h - phi1) / lambda;
    }
    double v = R(VR_V);
    R(VR_X) += v * phi1 + a * phi2;
    R(VR_V) = v * exp(-z) + a * phi1;
    return fmi2OK;
}

const Model MODEL = {
    .name = "Colliding",
    .guid = "{e51d9c07-2b86-4a3f-b0c4-7d1a6f3e8213}",
    .reals = REALS,
    .n_reals = sizeof REALS / sizeof REALS[0],
    .can_get_set_state = 1,
    .can_reset = 1,
    .initialize = initialize,
    .do_step = do_step,
    .update = update,
};
