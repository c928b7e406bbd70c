"""The Modelica library declares the same interface as the FMUs: the tables of components.py.

For CurrentLoop, Cart, Pendulum and Controller, every parameter, input and output (name, causality,
type, unit, default, description) and the class description must equal the FMU's
variable table, and a public local the two share (mode, stuck, F_F, ...) must agree in
unit and description. Only the FMU's internals are exempt: `solver_step` (the step of
the FMU's own integrator), `t_mode` and the Controller's `t_sample` (a Modelica tool
records events itself) and the
FMI derivative name `der(I_mean)`. Defaults are compared exactly: a changed digit on
either side is drift.
"""

from __future__ import annotations

import dataclasses
import math
import re

import pytest
import rumoca

from modelica_declarations import LIBRARY, ModelicaClass, ModelicaSyntaxError, evaluate, parse_class, read_class
from pendfmu.components import ALL_COMPONENTS, Component

# The RigController (issue 27) has no Modelica class yet: its law is pendfmu/control and its C twin.
COMPONENTS = {name: component for name, component in ALL_COMPONENTS.items() if name != "RigController"}

FMU_ONLY = {"solver_step", "t_mode", "t_sample", "der(I_mean)", "der(F_e)"}
PUBLIC = ("parameter", "input", "output")


def interface_differences(component: Component, mo: ModelicaClass) -> list[str]:
    """Every way the Modelica class differs from the FMU's table, one readable line each."""
    out = []
    if mo.name != component.name:
        out.append(f"class name {mo.name!r} != FMU {component.name!r}")
    if mo.description != component.description:
        out.append(f"class description {mo.description!r} != FMU {component.description!r}")
    table = {v.name: v for v in component.variables if v.name not in FMU_ONLY}
    public = {d.name: d for d in mo.declarations.values() if not d.protected}
    for name, var in table.items():
        decl = public.get(name)
        if decl is None:
            if var.causality in PUBLIC:
                out.append(f"{name}: FMU {var.causality} missing in Modelica")
            continue
        if decl.causality != var.causality:
            out.append(f"{name}: Modelica {decl.causality} != FMU {var.causality}")
        if decl.type != var.type:
            out.append(f"{name}: Modelica type {decl.type} != FMU {var.type}")
        if decl.unit != var.unit:
            out.append(f"{name}: Modelica unit {decl.unit!r} != FMU {var.unit!r}")
        if decl.description != var.description:
            out.append(f"{name}: Modelica description {decl.description!r} != FMU {var.description!r}")
        if var.causality in ("parameter", "input"):
            start = decl.start
            if start is None or start != var.start:
                out.append(f"{name}: Modelica default {start!r} != FMU start {var.start!r}")
    for name, decl in public.items():
        if name not in table and (decl.causality in PUBLIC or decl.type in ("Real", "Integer", "Boolean")):
            out.append(f"{name}: Modelica public {decl.causality} {decl.type} that the FMU does not have")
    return out


@pytest.mark.parametrize("name", sorted(COMPONENTS))
def test_modelica_class_matches_fmu_table(name):
    differences = interface_differences(COMPONENTS[name], read_class(name))
    assert differences == [], f"{name}.mo and pendfmu/components.py disagree:\n" + "\n".join(differences)


@pytest.mark.parametrize("name", sorted(COMPONENTS))
def test_every_public_fmu_variable_is_compared(name):
    """Guard against a vacuous comparison: the Modelica class has every FMU parameter,
    input and output (solver_step aside), and nothing public besides the shared locals."""
    mo = read_class(name)
    fmu = {v.name for v in COMPONENTS[name].variables if v.causality in PUBLIC} - FMU_ONLY
    modelica = {d.name for d in mo.declarations.values() if not d.protected and d.causality in PUBLIC}
    assert modelica == fmu
    assert len(fmu) >= 6


def _altered(component: Component, target: str, **changes) -> Component:
    variables = tuple(dataclasses.replace(v, **changes) if v.name == target else v for v in component.variables)
    return dataclasses.replace(component, variables=variables)


@pytest.mark.parametrize(
    "variable, changes, expected",
    [
        ("k_M", dict(unit="N.m"), "unit"),
        ("k_D", dict(start=628.0), "default"),
        ("phi", dict(start=3.14159), "default"),
        ("F_Sc", dict(description="Stiction force"), "description"),
        ("eta", dict(name="efficiency"), "missing in Modelica"),
        ("I", dict(causality="parameter"), "Modelica input != FMU parameter"),
        ("mode", dict(description="Mode"), "description"),
    ],
)
def test_drift_of_the_fmu_table_is_detected(variable, changes, expected):
    """A deliberately altered copy of the Cart table no longer matches Cart.mo."""
    differences = interface_differences(_altered(COMPONENTS["Cart"], variable, **changes), read_class("Cart"))
    assert any(expected in line for line in differences), differences


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ('T_Kp(unit = "N.m") = 2e-3', 'T_Kp(unit = "N.m") = 2.1e-3', "T_Kp: Modelica default"),
        ('J_p(unit = "kg.m2")', 'J_p(unit = "kg.m^2")', "J_p: Modelica unit"),
        ("input Real a(", "parameter Real a(", "a: Modelica parameter != FMU input"),
        ('"Angular speed"', '"Angular velocity"', "w: Modelica description"),
        ("= pi ", "= pi/2 ", "phi0: Modelica default"),
        ("  Real T_F(", "  output Real T_F(", "T_F: Modelica output != FMU local"),
    ],
)
def test_drift_of_the_modelica_class_is_detected(old, new, expected):
    """A deliberately altered copy of Pendulum.mo no longer matches the Pendulum table."""
    text = (LIBRARY / "Pendulum.mo").read_text(encoding="utf-8")
    assert text.count(old) == 1, f"the test's anchor {old!r} is gone from Pendulum.mo"
    differences = interface_differences(COMPONENTS["Pendulum"], parse_class(text.replace(old, new)))
    assert any(line.startswith(expected) for line in differences), differences


@pytest.mark.parametrize("name", sorted(COMPONENTS))
def test_rumoca_reads_the_same_parameters(name):
    """A second, independent reading: rumoca's own flattening gives each public parameter
    the unit, description and value of the FMU table (so the small reader above is not
    misreading the files)."""
    model = rumoca.Session(roots=[str(LIBRARY.parent)]).load(str(LIBRARY / "package.mo"), model=f"PendulumID.{name}")
    for var in COMPONENTS[name].variables:
        if var.causality == "parameter" and var.name not in FMU_ONLY:
            info = model.parameters[var.name]
            assert (info.unit or "", info.description) == (var.unit, var.description), var.name
            assert info.value == var.start, var.name
        elif var.causality == "input":
            info = model.inputs[var.name]
            assert (info.unit or "", info.description) == (var.unit, var.description), var.name


def test_package_order_lists_every_class_file():
    """OpenModelica and Dymola read package.order: each directory's file must list exactly
    its classes (and the package's constants), and each file's `within` must match."""
    for directory in [LIBRARY, *[d for d in LIBRARY.rglob("*") if d.is_dir()]]:
        order = (directory / "package.order").read_text(encoding="utf-8").split()
        files = {p.stem for p in directory.glob("*.mo") if p.name != "package.mo"}
        packages = {d.name for d in directory.iterdir() if (d / "package.mo").is_file()}
        constants = set(re.findall(r"^\s*constant\s+\w+\s+(\w+)", (directory / "package.mo").read_text(), re.M))
        assert sorted(order) == sorted(files | packages | constants), directory
        prefix = ".".join(directory.relative_to(LIBRARY.parent).parts)
        for path in directory.glob("*.mo"):
            within = prefix if path.name != "package.mo" else prefix.rpartition(".")[0]
            assert path.read_text(encoding="utf-8").startswith(f"within {within};".replace("within ;", "within;")), path


def test_reader_rejects_what_it_cannot_read():
    with pytest.raises(ModelicaSyntaxError, match="extends"):
        parse_class('within X;\nmodel M\n  extends Base;\nend M;\n', "M.mo")
    with pytest.raises(ModelicaSyntaxError, match="not a declaration"):
        parse_class("model M\n  Real;\nend M;\n", "M.mo")
    with pytest.raises(ModelicaSyntaxError, match="not a constant expression"):
        evaluate("sqrt(2)")
    with pytest.raises(FileNotFoundError, match="NoSuchClass.mo"):
        read_class("NoSuchClass")
    assert evaluate("pi + 0.5") == math.pi + 0.5
