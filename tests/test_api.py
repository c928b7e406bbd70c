"""The public API is what pendfmu.__all__ lists, where the package docstring says it is,
with the parameters it documents: a change here is a change users see (issue 13).
Everything else may move."""

from __future__ import annotations

import importlib
import inspect

import pendfmu

PUBLIC = ["__version__", "fit", "compare_laws", "FitSpec", "FitResult", "Estimate", "read_result", "write_report", "export_result",
          "GlobalOptions", "Model", "Recording", "read_recording", "write_recording"]
FIT_PARAMETERS = ["target", "recordings", "params", "progress", "checkpoint", "warn", "strict", "options"]
SPEC_FIELDS = ["target", "recordings", "params", "free", "fix", "bounds", "drive", "match", "initial", "interpolation",
               "per_recording", "windows", "segment", "start", "cost", "harmonic", "seed", "global_search",
               "uncertainty", "replicates"]


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


def test_the_specification_keeps_its_fields_and_documents_each():
    """fit's keywords are FitSpec's fields: each is named in fit's docstring and described in
    FitSpec's Attributes section."""
    import dataclasses

    assert [f.name for f in dataclasses.fields(pendfmu.FitSpec)] == SPEC_FIELDS
    attributes = pendfmu.FitSpec.__doc__.split("Attributes", 1)[1]
    for name in SPEC_FIELDS:
        assert f"\n    {name}" in attributes or f", {name}" in attributes, f"FitSpec does not describe {name!r}"
        assert name in pendfmu.fit.__doc__ or name in ("target", "recordings"), name


def test_every_public_callable_says_what_it_does():
    for name in PUBLIC[1:]:
        assert (getattr(pendfmu, name).__doc__ or "").strip(), name


def test_the_result_keeps_its_fields():
    fields = [f for f in pendfmu.FitResult.__dataclass_fields__]
    for name in ("stage", "parameters", "estimates", "correlation", "cost", "nrmse", "nfev", "failures", "seconds",
                 "notes", "warnings", "uncertainty"):
        assert name in fields, name
