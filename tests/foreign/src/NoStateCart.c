/* NoStateCart: a cart with viscous friction only, m v' = k u - c v, as a Co-Simulation FMU
   that, like many tool exports, cannot save its state (canGetAndSetFMUstate false) and cannot
   be reset (fmi2Reset returns fmi2Error): a host has to free it and instantiate again for
   every run. Its step is the exact solution for an input held over the step. */

#include <math.h>

#include "foreign.h"

enum { VR_U = 1, VR_X = 2, VR_V = 3, VR_M = 4, VR_K = 5, VR_C = 6, VR_X0 = 7, VR_V0 = 8 };

static const RealVariable REALS[] = {
    {VR_U, "u", INPUT, 0.0, -INFINITY, INFINITY, 0, "the voltage"},
    {VR_X, "x", OUTPUT, 0.0, -INFINITY, INFINITY, 0, "the position"},
    {VR_V, "v", OUTPUT, 0.0, -INFINITY, INFINITY, 0, "the speed"},
    {VR_M, "m", PARAMETER, 1.0, 0.0, INFINITY, 1, "a mass"},
    {VR_K, "k", PARAMETER, 1.0, -INFINITY, INFINITY, 0, "the force gain"},
    {VR_C, "c", PARAMETER, 1.0, 0.0, INFINITY, 1, "the viscous coefficient"},
    {VR_X0, "x0", PARAMETER, 0.0, -INFINITY, INFINITY, 0, "the initial position"},
    {VR_V0, "v0", PARAMETER, 0.0, -INFINITY, INFINITY, 0, "the initial speed"},
};

#define R(vr) (c->d.r[vr])

static fmi2Status initialize(Instance *c) {
    R(VR_X) = R(VR_X0);
    R(VR_V) = R(VR_V0);
    return fmi2OK;
}

/* Exact for a held input: v -> v_end = k u / c with the rate c/m. */
static fmi2Status do_step(Instance *c, double h) {
    double rate = R(VR_C) / R(VR_M);
    double v_end = R(VR_K) * R(VR_U) / R(VR_C);
    double gone = -expm1(-rate * h); /* 1 - exp(-rate h), accurate for small steps */
    double dv = R(VR_V) - v_end;
    R(VR_X) += v_end * h + dv * gone / rate;
    R(VR_V) = v_end + dv * (1.0 - gone);
    return fmi2OK;
}

const Model MODEL = {
    .name = "NoStateCart",
    .guid = "{0b9d7e44-5a0c-4f7e-8c51-2d2e0c6f4b13}",
    .reals = REALS,
    .n_reals = sizeof REALS / sizeof REALS[0],
    .can_get_set_state = 0,
    .can_reset = 0,
    .initialize = initialize,
    .do_step = do_step,
};
