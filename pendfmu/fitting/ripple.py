"""The current stage's PWM ripple: found in the residual's spectrum, then fitted.

A sinusoid's frequency makes a cost with many local minima, so it is seeded from the
periodogram of the lag fit's residual rather than searched (MODEL.md: the converter's
harmonic a_h sin(2 pi f_h t + phase_h) on the measured current).
"""

from __future__ import annotations

import math

import numpy as np

from pendfmu.fitting.checkpoint import Checkpoint
from pendfmu.fitting.identification import fit
from pendfmu.fitting.optimizer import GlobalOptions
from pendfmu.fitting.result import FitResult


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


def fit_current(recordings, params=None, seed: int = 0, cost: str = "plain", harmonic: bool | None = None,
                global_search: GlobalOptions | None = None, progress: bool | None = None,
                checkpoint: Checkpoint | None = None, **options) -> FitResult:
    """The current stage, with the PWM ripple: unless harmonic=False, a harmonic found in
    the residual of the lag fit is added to the free parameters and fitted with them."""
    uncertainty = options.pop("uncertainty", "bootstrap")
    settled = harmonic is False or any(name in (options.get("free") or ()) for name in HARMONIC)
    first = fit("current", recordings, params, seed=seed, cost=cost, global_search=global_search,
                progress=progress, checkpoint=checkpoint, uncertainty=uncertainty if settled else "jacobian",
                **options)
    if settled:
        return first
    found = detect_harmonic(first)
    options.pop("warn", None)  # the recordings' warnings were given by the first pass
    if found is None:
        # The lag alone it is: its intervals, by the method asked for, from the optimum found.
        final = fit("current", recordings, {**(params or {}), **_fitted(first)}, seed=seed, cost=cost,
                    global_search=GlobalOptions(enabled=False), progress=progress, uncertainty=uncertainty, **options)
        final.notes.append("no PWM ripple found in the residual (harmonic not fitted)")
        final.nfev += first.nfev
        final.seconds += first.seconds
        return final
    bounds = {"a_h": (0.0, max(4 * found["a_h"], 1e-3)), "f_h": (0.9 * found["f_h"], 1.1 * found["f_h"]),
              "phase_h": (found["phase_h"] - math.pi, found["phase_h"] + math.pi), **options.pop("bounds", {})}
    second = fit("current", recordings, {**first.parameters, **found}, free=list(HARMONIC), bounds=bounds,
                 seed=seed, cost=cost, global_search=GlobalOptions(enabled=False), progress=progress,
                 uncertainty=uncertainty, **options)
    second.notes.append(f"PWM ripple found in the residual near {found['f_h']:.6g} Hz and fitted")
    second.nfev += first.nfev
    second.seconds += first.seconds
    return second


def _fitted(result: FitResult) -> dict[str, float]:
    """The stage's fitted rig parameters (not per-recording initial states)."""
    return {label: e.value for label, e in result.estimates.items() if "[" not in label}
