/* The hybrid integrator behind fmi2DoStep.
 *
 * Classic RK4 on a fixed internal step that divides the communication interval evenly,
 * so every step lands exactly on the communication point. Where the model has an exact
 * solution for the step (model_exact_step), it replaces RK4 and spans the whole interval.
 * After each step the event indicators are compared with their values at the start of
 * the step; an indicator that went from >= 0 to < 0 marks a mode change inside the step.
 * Its time is located by Illinois (modified regula falsi) root finding on
 * g(tau) = z(t + tau, step(x, tau)), the indicator along the step's own solution (exact, or
 * the RK4 polynomial), to a bracket narrower than EVENT_TIME_TOLERANCE. The step is cut
 * there, the mode updated (event iteration), and integration continues from the event.
 * Because a sub-step is the same formula, the located time carries the integrator's own
 * accuracy, not an interpolation's.
 */
#include <math.h>
#include <string.h>

#include "framework.h"

/* Inline every call the function makes, the model's equations included (they are in
 * another file; -flto makes them visible). Why: the compiler's own heuristics keep
 * model_derivatives out of line, and the call, the spilled registers and the derivatives
 * passed through memory were a quarter of a pendulum step; inlined into the RK4 step, the
 * C loop over the rig went from 0.31 to 0.22 us per communication step. */
#if defined(__GNUC__)
#define FLATTEN __attribute__((flatten))
#else
#define FLATTEN
#endif

/* Evaluate the inputs at time t from the polynomial set by fmi2SetRealInputDerivatives.
 * Without derivatives for the current step, inputs are held (zero-order hold). */
void solver_inputs_at(Instance *inst, double t) {
    DynamicState *s = &inst->s;
    if (!s->uder_set) return;
    const double dt = t - s->uder_time;
    for (int j = 0; j < N_INPUTS; j++) {
        const unsigned vr = INPUT_VR[j];
        const int order = s->uder_order[vr];
        if (!order) continue; /* held: r[vr] is u_base[vr] already */
        double sum = s->taylor[vr][order - 1]; /* Horner */
        for (int k = order - 1; k >= 1; k--) sum = sum * dt + s->taylor[vr][k - 1];
        s->r[vr] = s->u_base[vr] + sum * dt;
    }
}

static void indicators_at(Instance *inst, double t, const double *x, double *z) {
    solver_inputs_at(inst, t);
    model_event_indicators(inst, t, x, z);
}

bool input_is_linear(const Instance *inst, unsigned vr, double *slope) {
    const DynamicState *s = &inst->s;
    const int order = s->uder_set ? s->uder_order[vr] : 0;
    *slope = order >= 1 ? s->taylor[vr][0] : 0.0;
    return order <= 1;
}

static void rk4_step(Instance *inst, double t, const double *x, double h, double *x_out);

/* One step of size h from (t, x) into x_out: the model's exact solution where it has one,
 * else classic Runge-Kutta. */
static void advance(Instance *inst, double t, const double *x, double h, double *x_out) {
    solver_inputs_at(inst, t);
    if (!model_exact_step(inst, t, x, h, x_out)) rk4_step(inst, t, x, h, x_out);
}

#if SECOND_ORDER
/* One classic Runge-Kutta step of size h from (t, x) into x_out, for a joint: states
 * (p, v) with dp/dt = v and dv/dt = f(t, p, v), then any further first-order states q
 * (dq/dt = g, the Cart's electrical lag) in the classic form. The inputs are already
 * evaluated at t. Substituting k_p = v + c h f into the classic formulas gives its Nystrom
 * form, the same method up to rounding:
 *     f1 = f(t, p, v)
 *     f2 = f(t + h/2, p + h/2 v, v + h/2 f1)
 *     f3 = f(t + h/2, p + h/2 v + h^2/4 f1, v + h/2 f2)
 *     f4 = f(t + h, p + h v + h^2/2 f2, v + h f3)
 *     p' = p + h v + h^2/6 (f1 + f2 + f3),   v' = v + h/6 (f1 + 2 f2 + 2 f3 + f4)
 * Why: each stage position no longer waits for the previous stage's speed. The position of
 * stage 2 needs no stage at all, so the processor evaluates its trigonometry alongside
 * stage 1, and the chain of dependent operations through a step is about half as long.
 * The further states do not change the arithmetic of (p, v): a model whose extra states
 * are constant (derivative 0) steps (p, v) bit for bit as a two-state joint. */
FLATTEN static void rk4_step(Instance *inst, double t, const double *x, double h, double *x_out) {
    const double p = x[0], v = x[1], half = 0.5 * h;
    double stage[N_STATES_ALLOC], d1[N_STATES_ALLOC], d2[N_STATES_ALLOC], d3[N_STATES_ALLOC], d4[N_STATES_ALLOC];
    model_derivatives(inst, t, x, d1);
    const double f1 = d1[1];
    solver_inputs_at(inst, t + half);
    const double p_half = p + half * v;
    stage[0] = p_half;
    stage[1] = v + half * f1;
    for (int j = 2; j < N_STATES; j++) stage[j] = x[j] + half * d1[j];
    model_derivatives(inst, t + half, stage, d2);
    const double f2 = d2[1];
    stage[0] = p_half + (half * half) * f1;
    stage[1] = v + half * f2;
    for (int j = 2; j < N_STATES; j++) stage[j] = x[j] + half * d2[j];
    model_derivatives(inst, t + half, stage, d3);
    const double f3 = d3[1];
    solver_inputs_at(inst, t + h);
    const double p_full = p + h * v;
    stage[0] = p_full + (h * half) * f2;
    stage[1] = v + h * f3;
    for (int j = 2; j < N_STATES; j++) stage[j] = x[j] + h * d3[j];
    model_derivatives(inst, t + h, stage, d4);
    const double f4 = d4[1];
    x_out[0] = p_full + (h * h / 6.0) * (f1 + f2 + f3);
    x_out[1] = v + h / 6.0 * (f1 + 2.0 * f2 + 2.0 * f3 + f4);
    for (int j = 2; j < N_STATES; j++) x_out[j] = x[j] + h / 6.0 * (d1[j] + 2.0 * d2[j] + 2.0 * d3[j] + d4[j]);
}
#else
static void derivatives_at(Instance *inst, double t, const double *x, double *dx) {
    solver_inputs_at(inst, t);
    model_derivatives(inst, t, x, dx);
}

/* One classic Runge-Kutta step of size h from (t, x) into x_out; the inputs are already
 * evaluated at t (by the caller). */
FLATTEN static void rk4_step(Instance *inst, double t, const double *x, double h, double *x_out) {
    double k1[N_STATES_ALLOC], k2[N_STATES_ALLOC], k3[N_STATES_ALLOC], k4[N_STATES_ALLOC], tmp[N_STATES_ALLOC];
    model_derivatives(inst, t, x, k1);
    for (int j = 0; j < N_STATES; j++) tmp[j] = x[j] + 0.5 * h * k1[j];
    derivatives_at(inst, t + 0.5 * h, tmp, k2);
    for (int j = 0; j < N_STATES; j++) tmp[j] = x[j] + 0.5 * h * k2[j];
    derivatives_at(inst, t + 0.5 * h, tmp, k3);
    for (int j = 0; j < N_STATES; j++) tmp[j] = x[j] + h * k3[j];
    derivatives_at(inst, t + h, tmp, k4);
    for (int j = 0; j < N_STATES; j++)
        x_out[j] = x[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
}
#endif

/* Indicator `which` after a sub-step of length tau from (t, x). */
static double indicator_after(Instance *inst, double t, const double *x, double tau, int which) {
    double x_tau[N_STATES_ALLOC], z[N_EVENT_INDICATORS_ALLOC];
    advance(inst, t, x, tau, x_tau);
    indicators_at(inst, t + tau, x_tau, z);
    return z[which];
}

/* The first time in (0, h] at which indicator `which` turns negative, given
 * g(0) = g_lo >= 0 and g(h) = g_hi < 0. Returns the right end of the final bracket,
 * where the indicator is already negative, so the event is never taken too early. */
static double locate_event(Instance *inst, double t, const double *x, double h, int which,
                           double g_lo, double g_hi) {
    double a = 0.0, b = h, fa = g_lo, fb = g_hi;
    int last_side = 0;
    for (int iter = 0; iter < 200 && b - a > EVENT_TIME_TOLERANCE; iter++) {
        double c = (fa - fb) != 0.0 ? a + fa * (b - a) / (fa - fb) : 0.5 * (a + b);
        if (!(c > a && c < b)) c = 0.5 * (a + b);
        const double fc = indicator_after(inst, t, x, c, which);
        if (fc < 0.0) {
            b = c;
            fb = fc;
            if (last_side == -1) fa *= 0.5; /* Illinois: halve the stale end */
            last_side = -1;
        } else {
            a = c;
            fa = fc;
            if (last_side == +1) fb *= 0.5;
            last_side = +1;
        }
    }
    return b;
}

static bool indicators_consistent(const double *z) {
    for (int k = 0; k < N_EVENT_INDICATORS; k++)
        if (z[k] < 0.0) return false;
    return true;
}

/* Update the mode at time t until it is consistent with the states and inputs; z receives
 * the indicators of the consistent mode. */
static bool event_iteration(Instance *inst, double t, double *z) {
    for (int iter = 0; iter < MAX_EVENT_ITERATIONS; iter++) {
        solver_inputs_at(inst, t);
        const int old_mode = MODE;
        const bool changed = model_update_mode(inst, t, inst->s.x);
        if (changed && MODE != old_mode) {
            inst->s.event_count++;
            inst->s.r[VR_t_mode] = t;
            log_event(inst, "t = %.12g s: mode %d -> %d", t, old_mode, MODE);
        }
        model_event_indicators(inst, t, inst->s.x, z);
        if (!changed && indicators_consistent(z)) return true;
    }
    log_error(inst, "t = %.12g s: no consistent mode after %d event iterations (last mode %d)", t,
              MAX_EVENT_ITERATIONS, MODE);
    return false;
}

bool solver_event_iteration(Instance *inst, double t) {
    double z[N_EVENT_INDICATORS_ALLOC];
    return event_iteration(inst, t, z);
}

bool solver_initialize(Instance *inst) {
#if HAS_SOLVER_STEP
    inst->s.h_rk4 = fmin(R(solver_step), model_max_step(inst));
#else
    inst->s.h_rk4 = model_max_step(inst);
#endif
    model_initial_states(inst);
    inst->s.r[VR_t_mode] = inst->s.time;
    return solver_event_iteration(inst, inst->s.time);
}

static bool all_finite(const double *x) {
    for (int j = 0; j < N_STATES; j++)
        if (!isfinite(x[j])) return false;
    return true;
}

/* Integrate from the current time to t_end. Returns false (after logging) on failure. */
FLATTEN bool solver_do_step(Instance *inst, double t_end) {
    DynamicState *s = &inst->s;
    const double t_start = s->time;
    double t = t_start;
    double z0[N_EVENT_INDICATORS_ALLOC], z1[N_EVENT_INDICATORS_ALLOC], x1[N_STATES_ALLOC];

    /* Inputs may have jumped at the communication point: make the mode consistent. */
    if (!event_iteration(inst, t, z0)) return false;

    while (t < t_end) {
        const double remaining = t_end - t;
        /* An exact solution is accurate over any length: it goes to t_end (or the next event)
         * at once. RK4 takes equal steps of at most h_rk4. */
        double h = remaining;
        solver_inputs_at(inst, t);
        if (!model_exact_step(inst, t, s->x, h, x1)) {
            const double n_steps = ceil(remaining / s->h_rk4 * (1.0 - 1e-12));
            if (!(s->h_rk4 > 0.0) || !(n_steps <= MAX_INTERNAL_STEPS)) {
                log_error(inst, "t = %.12g s: a step of %g s needs internal steps of %g s (more than %.0f): the "
                          "parameters make the model too stiff, or solver_step is too small", t, t_end - t_start,
                          s->h_rk4, MAX_INTERNAL_STEPS);
                return false;
            }
            if (n_steps > 1.0) h = remaining / n_steps;
            rk4_step(inst, t, s->x, h, x1);
        }
        indicators_at(inst, t + h, x1, z1);

        double tau = h;
        int which = -1;
        for (int k = 0; k < N_EVENT_INDICATORS; k++) {
            if (z0[k] >= 0.0 && z1[k] < 0.0) {
                const double tau_k = locate_event(inst, t, s->x, h, k, z0[k], z1[k]);
                if (which < 0 || tau_k < tau) {
                    tau = tau_k;
                    which = k;
                }
            }
        }
        if (which >= 0 && tau < h) advance(inst, t, s->x, tau, x1);
        memcpy(s->x, x1, N_STATES * sizeof(double));
        t = (tau == remaining) ? t_end : t + tau;
        s->time = t;
        if (!all_finite(s->x)) {
            log_error(inst, "t = %.12g s: the solution is no longer finite (check parameters and inputs)", t);
            return false;
        }
        if (which >= 0) {
            if (!event_iteration(inst, t, z0)) return false;
        } else {
            memcpy(z0, z1, sizeof z0);
        }
    }
    s->time = t_end;
    solver_inputs_at(inst, t_end);
    return true;
}
