"""The current stage's PWM ripple: found in the residual's spectrum, then fitted.

A sinusoid's frequency makes a cost with many local minima, so it is seeded from the
periodogram of the lag fit's residual rather than searched (docs/user-guide/model.md: the
converter's harmonic a_h sin(2 pi f_h t + phase_h) on the measured current).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from pendfmu.fitting.problem import given_values
from pendfmu.fitting.labels import is_own
from pendfmu.fitting.result import FitResult
from pendfmu.fitting.spec import FitSpec


HARMONIC = ("a_h", "f_h", "phase_h")
HARMONIC_SIGNIFICANCE = 4.0  # peak amplitude over the residual's noise amplitude, to count as ripple


def detect_harmonic(result: FitResult) -> dict[str, float] | None:
    """The PWM ripple left in a current fit's residual: the strongest periodogram peak of
    the residuals (evenly sampled recordings), if it stands well above the noise floor.
    A sinusoid's frequency makes a cost with many local minima, so it is seeded from the
    spectrum rather than searched; amplitude and phase follow by linear least squares."""
    best = None
    for fit_ in result.experiments:
        time, residual = fit_.time, fit_.recorded["I"] - fit_.simulated["I"]
        steps = np.diff(time)
        if len(time) < 64 or np.ptp(steps) > 1e-6 * steps.mean():
            continue
        spectrum = np.abs(np.fft.rfft(residual - residual.mean())) * 2 / len(residual)
        frequencies = np.fft.rfftfreq(len(residual), steps.mean())
        k = int(np.argmax(spectrum[1:])) + 1
        floor = float(np.median(spectrum[1:])) or 1e-300
        if spectrum[k] > HARMONIC_SIGNIFICANCE * floor * 3 and (best is None or spectrum[k] > best[0]):
            # refine the frequency by a parabola through the peak's neighbours (log amplitude)
            if 1 <= k < len(spectrum) - 1:
                a, b, c = np.log(spectrum[k - 1:k + 2] + 1e-300)
                shift = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) else 0.0
            else:
                shift = 0.0
            frequency = float(frequencies[k] + shift * (frequencies[1] - frequencies[0]))
            basis = np.column_stack([np.sin(2 * np.pi * frequency * time), np.cos(2 * np.pi * frequency * time)])
            (s, c), *_ = np.linalg.lstsq(basis, residual, rcond=None)
            best = (float(spectrum[k]), {"a_h": float(math.hypot(s, c)), "f_h": frequency,
                                         "phase_h": float(math.atan2(c, s))})
    return best[1] if best else None


def looks_for_ripple(spec: FitSpec) -> bool:
    """Whether a fit looks for the PWM ripple: the current stage, unless told not to
    (harmonic 'off') or told what to do with the harmonic's parameters (free or fixed)."""
    named = any(name in (*spec.free, *spec.fix) for name in HARMONIC)
    return spec.target == "current" and spec.harmonic == "auto" and not named


def fit_with_ripple(spec: FitSpec, solve: Callable[[FitSpec, bool], FitResult]) -> FitResult:
    """The current stage with its PWM ripple: the lag alone first (its intervals the fast
    ones), then, if a harmonic stands out of that fit's residual, the harmonic added to the
    free parameters and fitted from there; if none does, the lag's intervals by the
    method asked for. `solve(spec, final)` solves one pass: the first, or a final one (its
    recordings' warnings were given by the first, and it is the one validated)."""
    first = solve(spec.with_options(uncertainty="jacobian", replicates=None), False)
    found = detect_harmonic(first)
    local = replace(spec.global_search, enabled=False)
    known = given_values(spec)
    if found is None:
        final = solve(spec.with_options(params={**known, **_fitted(first)}, global_search=local), True)
        final.notes.append("no PWM ripple found in the residual (harmonic not fitted)")
    else:
        bounds = {"a_h": (0.0, max(4 * found["a_h"], 1e-3)), "f_h": (0.9 * found["f_h"], 1.1 * found["f_h"]),
                  "phase_h": (found["phase_h"] - math.pi, found["phase_h"] + math.pi), **spec.bounds}
        final = solve(spec.with_options(params={**first.parameters, **found}, free=(*spec.free, *HARMONIC),
                                        bounds=bounds, global_search=local), True)
        final.notes.append(f"PWM ripple found in the residual near {found['f_h']:.6g} Hz and fitted")
    final.nfev += first.nfev
    final.seconds += first.seconds
    return final


def _fitted(result: FitResult) -> dict[str, float]:
    """The stage's fitted rig parameters (not per-recording initial states)."""
    return {key: e.value for key, e in result.estimates.items() if not is_own(key)}
