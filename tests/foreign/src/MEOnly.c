/* MEOnly: a damped oscillator pulled towards its input, as a Model Exchange FMU with no
   Co-Simulation interface (a host must bring its own solver, e.g. fmpy's CVode):

       x' = v,   v' = omega^2 (u - x) - 2 zeta omega v

   For a constant u it has a closed form, which the tests compare against. */

#include <math.h>

#include "foreign.h"

enum { VR_U = 1, VR_X = 2, VR_V = 3, VR_DER_X = 4, VR_DER_V = 5, VR_OMEGA = 6, VR_ZETA = 7, VR_X0 = 8, VR_V0 = 9 };

static const RealVariable REALS[] = {
    {VR_U, "u", INPUT, 0.0, -INFINITY, INFINITY, 0, "the target position"},
    {VR_X, "x", OUTPUT, 0.0, -INFINITY, INFINITY, 0, "the position"},
    {VR_V, "v", OUTPUT, 0.0, -INFINITY, INFINITY, 0, "the speed"},
    {VR_DER_X, "der(x)", LOCAL, 0.0, -INFINITY, INFINITY, 0, "the speed"},
    {VR_DER_V, "der(v)", LOCAL, 0.0, -INFINITY, INFINITY, 0, "the acceleration"},
    {VR_OMEGA, "omega", PARAMETER, 10.0, 0.0, INFINITY, 1, "the natural angular frequency"},
    {VR_ZETA, "zeta", PARAMETER, 0.1, 0.0, INFINITY, 0, "the damping ratio"},
    {VR_X0, "x0", PARAMETER, 0.0, -INFINITY, INFINITY, 0, "the initial position"},
    {VR_V0, "v0", PARAMETER, 0.0, -INFINITY, INFINITY, 0, "the initial speed"},
};

static const fmi2ValueReference STATES[] = {VR_X, VR_V};
static const fmi2ValueReference DERIVATIVES[] = {VR_DER_X, VR_DER_V};

#define R(vr) (c->d.r[vr])

static void derivatives(Instance *c) {
    double w = R(VR_OMEGA);
    R(VR_DER_X) = R(VR_V);
    R(VR_DER_V) = w * w * (R(VR_U) - R(VR_X)) - 2.0 * R(VR_ZETA) * w * R(VR_V);
}

static fmi2Status initialize(Instance *c) {
    R(VR_X) = R(VR_X0);
    R(VR_V) = R(VR_V0);
    derivatives(c);
    return fmi2OK;
}

const Model MODEL = {
    .name = "MEOnly",
    .guid = "{c3e8a1d0-7f42-4b19-a6d5-93b0e2f1c413}",
    .reals = REALS,
    .n_reals = sizeof REALS / sizeof REALS[0],
    .can_get_set_state = 0,
    .can_reset = 1,
    .initialize = initialize,
    .n_states = 2,
    .state_vrs = STATES,
    .derivative_vrs = DERIVATIVES,
    .update = derivatives,
};
