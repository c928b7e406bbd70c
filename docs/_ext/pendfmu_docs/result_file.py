"""The result file's reference (`pendfmu fit --out R.json`, FitResult.write_json): each field.

Which fields there are is generated: a small FitResult, with every optional part present,
is turned into the file's document by the code that writes result files
(FitResult.to_dict), and a provenance record by the code that records it
(pendfmu.fitting.provenance, on a stand-in for a solved problem). What each field means is
written here, in FIELDS, for the file (the Python objects' docstrings describe the
objects); a field the code writes that FIELDS does not describe, or one FIELDS describes
that the code no longer writes, is a warning, so the build fails until the page is right
again.
"""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
from sphinx.util import logging

from pendfmu_docs.markdown import plain, table

logger = logging.getLogger(__name__)

# Per part of the document (a dotted path; [] an element of a list, {} any key of a mapping),
# what each of its fields holds.
FIELDS = {
    "": {
        "parameters": "every parameter value the fit ran with, fitted and known, by name: the file `--params` "
                      "reads back (a later stage, `pendfmu export`, `pendfmu control`)",
        "stderr": "the standard error of each fitted parameter; null where none could be given",
        "ci95": "the 95 % interval `[low, high]` of each fitted parameter; a null side is unbounded, a null interval "
                "none could be given",
        "interval_method": "what gave each interval: `bootstrap`, `jacobian`, `sandwich`, `bounded`, ...",
        "correlation": "the estimates' correlations, `{name: {name: r}}`; null where a standard error is 0 or "
                       "undefined: what a derived quantity's interval needs besides the standard errors",
        "flags": "per estimate, what a user must know about it (at a bound, a wide interval, ...), as sentences",
        "flag_kinds": "the kind of each flag, in the same order, for programs: one of {kinds}",
        "initial": "the initial states estimated per recording, `{recording: {state: value}}`",
        "fit": "the fit's figures and messages (below)",
        "provenance": "where the result came from, enough to repeat the fit (below)",
        "recordings": "each fitted recording: its signals, recorded and simulated, and the values it ran with (below)",
        "predicted": "the recordings predicted with the result but not fitted (`fit all`: those with both x and "
                     "phi), as `recordings`",
        "replicates": "with bootstrap intervals only: per replicate, the rig's values its refits found; `pendfmu "
                      "control` verifies a design on them",
    },
    "fit": {
        "stage": "`current`, `cart`, `pendulum`, `all`, or the name of a user's model",
        "cost": "the cost at the optimum: half the sum of the squared residuals, each divided by its signal's error "
                "scale (the noise)",
        "nrmse": "per signal, the root-mean-square error over all recordings divided by the recorded range (`all`: "
                 "`stage.signal`)",
        "nfev": "how many simulations the fit ran",
        "failures": "how many of them failed (the model refused a value or a step)",
        "seconds": "the fit's wall-clock time",
        "notes": "what the fit did that a user may want to know",
        "warnings": "what looks wrong: suspicious data, residuals far above the noise, an estimate at a bound; "
                    "`--strict` exits with code 3 on any",
        "uncertainty": "how the intervals were made: method, replicates, time (`all`: per stage)",
        "validation": "per predicted recording, its errors: `<signal>_rms` and, with a stated resolution, "
                      "`<signal>_rms_steps`",
        "assessment": "whether the fit can be trusted: `verdict` (`adequate`, `model-inadequate`, `fit-failed`) "
                      "and the `evidence` that showed it (`all`: the worst stage's, and each stage's)",
        "model": "a user's FMU or SSP file (`--fmu`, `--system`); absent for pendfmu's own stages",
    },
    "recordings[]": {
        "name": "the recording's name: its file's stem, and for a window (`--window`) its span, `run@2-5s`",
        "samples": "how many samples it has; a long recording's arrays hold only its display envelope",
        "time": "the times [s] of the samples kept",
        "recorded": "per fitted signal, the recorded values (null: a missing sample)",
        "simulated": "per fitted signal, the simulated values at the same times",
        "resolution": "per signal, the quantization step the sidecar states",
        "scale": "per signal, the error scale (noise) the cost divides its residuals by",
        "rms": "per signal, the RMS error over every sample (not only those kept)",
        "values": "every parameter value this recording ran with",
        "overrides": "what its sidecar set (parameters, initial states)",
        "diagnostics": "per signal, the residual diagnostics over every sample (below)",
    },
    "recordings[].diagnostics{}": {
        "samples": "the finite residuals they are computed from (N of the white-noise band ±1.96/√N)",
        "step": "the median time between samples [s], to read lags as time",
        "lags": "the lags (in samples) at which the autocorrelation is kept",
        "acf": "the residuals' autocorrelation at those lags",
        "correlation_length": "how many samples the residuals stay correlated (1: white noise)",
        "amplitude": "the residual's mean in bins of the recorded value: `centre`, `mean`, `spread`, `count` per bin",
        "speed": "the same in bins of the signal's rate",
        "speed_from": "where the rate came from: a recorded rate signal, or the central difference",
    },
    "provenance": {
        "versions": "pendfmu's, Python's, numpy's, scipy's and fmpy's versions",
        "platform": "the operating system and machine",
        "date": "when the fit ran (UTC, ISO 8601)",
        "seed": "the seed of the global search",
        "inputs": "every input file: `path`, `bytes` and `sha256` (`predicted`: true for one only predicted)",
        "request": "the fit's specification as given (FitSpec's fields: {spec}); `fit all` records its stages' "
                   "set-ups instead",
        "stages": "per stage (or model), its set-up as fitted (below)",
        "command": "the command line that ran the fit (`pendfmu fit ...`)",
    },
    "provenance.stages{}": {
        "stage": "the stage's (or model's) name",
        "seed": "the seed of its global search",
        "cost": "the cost function's name",
        "model": "a user's FMU or SSP file; absent for pendfmu's stages",
        "free": "the fitted parameters (a recording's own: `name[recording]`)",
        "bounds": "each fitted parameter's search box `[low, high]`",
        "scale": "each fitted parameter's search scale: `log` or `linear`",
        "relative_to": "a fitted parameter searched relative to another (a box that moves with it)",
        "start": "each fitted parameter's start value",
        "fixed": "every value the stage ran with that was not fitted",
        "recordings": "per recording, what it was fitted with (below)",
        "search": "the global search's settings: `global`, `popsize`, `maxiter`, `workers`, `scheduler`",
        "uncertainty": "the intervals' method, and the bootstrap's replicates",
        "harmonic": "the current stage only: whether the PWM ripple was looked for (`auto`) or not (`off`)",
    },
    "provenance.stages{}.recordings{}": {
        "file": "the recording's file",
        "span": "the times fitted, `[start, end]` [s]",
        "drives": "each driven input: the recorded column and the interpolation",
        "match": "each compared output: the recorded column",
        "estimated": "the initial states estimated for this recording",
        "starts": "the known initial states it started from, `[parameter, source]`: the sidecar's, or a rate at a "
                  "turning point",
        "read_from": "what told each estimated initial state's search box",
        "initial": "the sidecar's known initial values",
        "sidecar": "the parameters its sidecar sets",
    },
}


def _experiment(name: str):
    from pendfmu.fitting.result import ExperimentFit

    time = np.linspace(0.0, 1.0, 64)
    wave = np.sin(7.0 * time) + 0.01 * np.cos(40.0 * time)
    return ExperimentFit(name, time, {"x": wave}, {"x": wave * 0.99}, resolution={"x": 1e-4}, scale={"x": 1e-3},
                         values={"m_c": 3.0}, overrides={"m_p": 0.0})


def sample_document() -> dict:
    """A result file's document with every optional part present (the fields only matter)."""
    from pendfmu.fitting.result import Estimate, FitResult, Flag

    estimate = Estimate("m_c", 3.0, 0.1, (2.8, 3.2), 0.5, 10.0, [Flag("a note", "note")], "bootstrap")
    result = FitResult(stage="cart", parameters={"m_c": 3.0}, estimates={"m_c": estimate},
                       correlation={"m_c": {"m_c": 1.0}}, cost=1.0, nrmse={"x": 0.01}, nfev=10, failures=0, seconds=1.0,
                       experiments=[_experiment("run")], initial={"run": {"v0": 0.0}}, notes=["a note"],
                       validation={"run": {"x_rms": 0.1}}, warnings=["a warning"], uncertainty={"method": "bootstrap"},
                       model="model.fmu", replicates=[{"m_c": 3.0}], provenance=_provenance(),
                       predicted=[_experiment("predicted")], assessment={"verdict": "adequate", "evidence": []})
    return result.to_dict()


def _provenance() -> dict:
    """A provenance record by pendfmu.fitting.provenance's own functions, the problem and the
    specification stood in for by the attributes the record reads of them."""
    from pendfmu.fitting import provenance

    free = [SimpleNamespace(name="m_c", experiment=None, label="m_c", low=0.5, high=10.0, log=True,
                            relative_to="m_p")]
    recording = SimpleNamespace(time=[0.0, 1.0], path="run.csv", initial={"x": 0.0}, parameters={"m_p": 0.0})
    experiment = SimpleNamespace(name="run", recording=recording, match={"x": "x"}, estimated={"v0"},
                                 setup=SimpleNamespace(drives={"I": ("I", "linear")},
                                                       starts=[SimpleNamespace(parameter="x0", source="sidecar")]),
                                 read_from={"v0": SimpleNamespace(source="the recording")})
    search = SimpleNamespace(enabled=True, popsize=8, maxiter=20, workers=2, scheduler=None)
    spec = SimpleNamespace(seed_value=0, cost="linear", global_search=search, uncertainty="bootstrap",
                           replicate_count=24, harmonic="auto", request=lambda: {})
    record, other = (provenance.fit_record(SimpleNamespace(name=name, free=free, model_file=model, values={"m_c": 3.0},
                                                           experiments=[experiment]), spec, [3.0])
                     for name, model in (("current", None), ("model", "model.fmu")))
    # one fit's record (fit all's, merged from its stages', has no request), with a stage
    # (current: harmonic) and a model (its file) side by side
    return provenance.with_command({**record, "stages": {**record["stages"], **other["stages"]}}, ["pendfmu", "fit"])


def _written(document, path: str) -> set[str]:
    """The fields at `path` (FIELDS' notation) of the document: the keys of every mapping there."""
    nodes = [document]
    for part in path.replace("[]", ".[]").replace("{}", ".{}").split("."):
        if part == "[]":
            nodes = [element for node in nodes for element in node]
        elif part == "{}":
            nodes = [value for node in nodes for value in node.values()]
        elif part:
            nodes = [node[part] for node in nodes]
    return {key for node in nodes for key in node}


def markdown(app=None) -> str:
    from pendfmu.fitting.result import FLAG_KINDS
    from pendfmu.fitting.spec import FitSpec

    document = sample_document()
    words = {"kinds": ", ".join(f"`{kind}`" for kind in FLAG_KINDS),
             "spec": ", ".join(f"`{f.name}`" for f in dataclasses.fields(FitSpec))}
    parts = []
    for path, fields in FIELDS.items():
        written = _written(document, path)
        for name in sorted(set(written) - set(fields)):
            logger.warning("the result file's %s holds %r, which docs/_ext/pendfmu_docs/result_file.py does not "
                           "describe", path or "top level", name)
        for name in sorted(set(fields) - set(written)):
            logger.warning("docs/_ext/pendfmu_docs/result_file.py describes %s %r, which the result file no longer "
                           "holds", path or "top level", name)
        rows = [[f"`{name}`", plain(text).replace("{kinds}", words["kinds"]).replace("{spec}", words["spec"])]
                for name, text in fields.items()]
        title = f"`{path}`" if path else "The document"
        parts.append(f"## {title}\n\n" + table(["field", "what it holds"], rows))
    return "\n".join(parts)
