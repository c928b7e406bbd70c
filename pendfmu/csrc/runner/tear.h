/* Root finding on a coupled group's tear signal: pendfmu/simulator/tear.py in C.
 *
 * The method and why (a secant/Illinois/bisection search on r(x) = G(x) - x, and at a jump
 * of G the step accepted with the consumers driven to the left limit g_pre and the FMU
 * states after the event) is explained in tear.py's docstring. This is the same class,
 * operation for operation and in the same order, so that the native engine stays
 * bit-identical to the Python one: change both together.
 */
#ifndef PENDFMU_TEAR_H
#define PENDFMU_TEAR_H

#include <math.h>

enum { TEAR_CONTINUE, TEAR_CONVERGED, TEAR_JUMP, TEAR_EXHAUSTED };
enum { TEAR_SEARCH, TEAR_LEFT_LIMIT, TEAR_POST_EVENT };

/* tear.py's JUMP_RESOLUTION: a bracket narrower than this fraction of the residual's jump
 * across it is a discontinuity. */
#define TEAR_JUMP_RESOLUTION 1e-5

typedef struct {
    double prediction, guess, slope, tolerance;
    int max_evaluations, phase, evaluations;
    double change, best;
    double x_last, r_last, g_last;
    int bracketed, bisecting;
    double a, ra, fa, ga, b, rb, fb, gb; /* bracket ends: guess, residual, Illinois residual, output */
    int kept;                            /* +1: the last bracketed update replaced a, -1: b, 0: none */
    double x_post, g_post, g_pre;
} TearSolver;

static void tear_start(TearSolver *s, double prediction, double slope, double tolerance, int max_evaluations) {
    s->prediction = prediction;
    s->guess = prediction;
    s->slope = slope;
    s->tolerance = tolerance;
    s->max_evaluations = max_evaluations;
    s->phase = TEAR_SEARCH;
    s->evaluations = 0;
    s->change = INFINITY;
    s->best = INFINITY;
    s->x_last = s->r_last = s->g_last = 0.0;
    s->bracketed = s->bisecting = 0;
    s->a = s->ra = s->fa = s->ga = 0.0;
    s->b = s->rb = s->fb = s->gb = 0.0;
    s->kept = 0;
    s->x_post = s->g_post = s->g_pre = 0.0;
}

static void tear_replace_end(TearSolver *s, double x, double r, double g) {
    if ((r > 0.0) == (s->ra > 0.0)) {
        s->a = x, s->ra = r, s->fa = r, s->ga = g;
        if (s->kept == 1) s->fb *= 0.5;
        s->kept = 1;
    } else {
        s->b = x, s->rb = r, s->fb = r, s->gb = g;
        if (s->kept == -1) s->fa *= 0.5;
        s->kept = -1;
    }
}

static int tear_at_jump(const TearSolver *s) {
    const double width = fabs(s->b - s->a);
    return width <= TEAR_JUMP_RESOLUTION * fabs(s->ra - s->rb) ||
           width <= s->tolerance * (1.0 + fmax(fabs(s->a), fabs(s->b)));
}

static double tear_next(const TearSolver *s, double x, double r, double g) {
    if (!s->bracketed) {
        const double guess = s->slope < 0.0 ? x - r / s->slope : g;
        return isfinite(guess) ? guess : g;
    }
    const double middle = 0.5 * (s->a + s->b);
    if (s->bisecting) return middle;
    const double guess = s->a - s->fa * (s->b - s->a) / (s->fb - s->fa);
    if (!(fmin(s->a, s->b) < guess && guess < fmax(s->a, s->b))) return middle;
    return guess;
}

/* The output g = G(x) of an evaluation at x: TEAR_CONTINUE (evaluate at s->guess next),
 * TEAR_CONVERGED, TEAR_JUMP (both: accept the step as last evaluated) or TEAR_EXHAUSTED. */
static int tear_update(TearSolver *s, double x, double g) {
    s->evaluations++;
    if (s->phase == TEAR_LEFT_LIMIT) {
        if (fabs(g - s->g_post) <= fabs(g - s->g_pre)) return TEAR_JUMP;
        s->phase = TEAR_POST_EVENT;
        s->guess = s->x_post;
        return TEAR_CONTINUE;
    }
    if (s->phase == TEAR_POST_EVENT) return TEAR_JUMP;
    const double r = g - x;
    s->change = fabs(r) / (1.0 + fabs(g));
    if (s->change <= s->tolerance) return TEAR_CONVERGED;
    const int improved = fabs(r) < 0.5 * s->best;
    s->best = fmin(s->best, fabs(r));
    if (s->evaluations > 1 && x != s->x_last) s->slope = (r - s->r_last) / (x - s->x_last);
    if (s->bracketed) {
        tear_replace_end(s, x, r, g);
        s->bisecting = !improved;
    } else if (s->evaluations > 1 && (r > 0.0) != (s->r_last > 0.0)) {
        s->bracketed = 1;
        s->a = s->x_last, s->ra = s->r_last, s->fa = s->r_last, s->ga = s->g_last;
        s->b = x, s->rb = r, s->fb = r, s->gb = g;
    }
    if (s->bracketed && tear_at_jump(s)) {
        if (fabs(s->ga - s->prediction) >= fabs(s->gb - s->prediction))
            s->x_post = s->a, s->g_post = s->ga, s->g_pre = s->gb;
        else
            s->x_post = s->b, s->g_post = s->gb, s->g_pre = s->ga;
        s->phase = TEAR_LEFT_LIMIT;
        s->guess = s->g_pre;
        return TEAR_CONTINUE;
    }
    if (s->evaluations >= s->max_evaluations) return TEAR_EXHAUSTED;
    s->guess = tear_next(s, x, r, g);
    s->x_last = x, s->r_last = r, s->g_last = g;
    return TEAR_CONTINUE;
}

#endif
