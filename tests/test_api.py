"""The public API is what pendfmu.__all__ lists, where the package docstring says it is,
with the parameters it documents: a change here is a change users see (issue 13).
Everything else may move."""

from __future__ import annotations

import importlib
import inspect

import pendfmu

PUBLIC = ["__version__", "fit", "fit_all", "fit_current", "FitResult", "Estimate", "GlobalOptions", "Model",
          "Recording", "read_recording", "write_recording"]
FIT_PARAMETERS = ["model", "recordings", "params", "free", "fix", "bounds", "seed", "drive", "cost", "global_search",
                  "progress", "checkpoint", "warn", "strict", "uncertainty", "replicates", "upstream", "match",
                  "initial", "interpolation", "per_recording", "windows", "segment", "start"]


def test_the_public_names_are_pinned():
    assert pendfmu.__all__ == PUBLIC
    assert sorted(dir(pendfmu)) == sorted(PUBLIC)


def test_each_name_lives_where_the_docstring_says():
    for name, module in pendfmu._API.items():
        assert getattr(pendfmu, name) is getattr(importlib.import_module(module), name), name
        assert module in pendfmu.__doc__ or name in pendfmu.__doc__, name


def test_fit_takes_the_documented_parameters():
    parameters = inspect.signature(pendfmu.fit).parameters
    assert list(parameters) == FIT_PARAMETERS
    documented = pendfmu.fit.__doc__
    for name in FIT_PARAMETERS:
        assert name in documented, f"fit's docstring does not describe {name!r}"


def test_every_public_callable_says_what_it_does():
    for name in PUBLIC[1:]:
        assert (getattr(pendfmu, name).__doc__ or "").strip(), name


def test_the_result_keeps_its_fields():
    fields = [f for f in pendfmu.FitResult.__dataclass_fields__]
    for name in ("stage", "parameters", "estimates", "correlation", "cost", "nrmse", "nfev", "failures", "seconds",
                 "notes", "warnings", "uncertainty"):
        assert name in fields, name
