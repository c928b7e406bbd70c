"""Shared fixtures: the FMUs are built (or found up to date) once per test session."""

from __future__ import annotations

import pytest

from pendfmu.fmubuild import build_all


@pytest.fixture(scope="session", autouse=True)
def built_fmus():
    return build_all()
