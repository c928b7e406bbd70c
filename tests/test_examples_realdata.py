"""The real-data examples run end to end: ``examples/realdata/<name>/run OUTDIR`` converts
the raw files, fits through pendfmu's command line and leaves ``OUTDIR/result.json``.

Each ``run`` is started as a user starts it (a separate process, this interpreter), so the
shebang script, its path set-up and its exit code are what is tested, not just the
functions behind it. The figures themselves are held to published and independent values
by test_realdata.py and test_realdata_fits.py, on the same conversions; here: the file, the
fitted parameters, and for EMPS the benchmark's terms; physical-cartpole's figures are held to
the published set here (its fits are model fits, not a stage). Each run once per session
(:func:`run_once`): about 80 s for the six (``--uncertainty jacobian``, as the examples'
READMEs say; physical-cartpole 40 s of it); skipped without the data.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import realdata as rd

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "realdata"
NAMES = sorted(p.name for p in EXAMPLES.iterdir() if (p / "run").is_file())
# Runs of minutes each (MultiArm's long decays, physical-cartpole's mass profile: about 3 min
# apiece on two busy cores): `make acceptance`, not `make test`. Their fits' intervals on the
# same data stay in make test (test_realdata_fits.py: MultiArm; the cartpole's conversion here).
LONG = {"MultiArm-Pendulum", "physical-cartpole"}


def running(names) -> list:
    """The examples as parameters, the LONG ones marked acceptance."""
    return [pytest.param(name, marks=pytest.mark.acceptance) if name in LONG else name for name in names]


def run(name: str, outdir: Path, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(EXAMPLES / name / "run"), str(outdir)], capture_output=True,
                          text=True, env={**os.environ, **env}, timeout=600)


def test_every_example_has_an_executable_run_and_a_readme():
    assert set(NAMES) >= {"kord-stk", "MultiArm-Pendulum", "friction-identification", "rotary-inverted-pendulum",
                          "EMPS"}
    for name in NAMES:
        script = EXAMPLES / name / "run"
        assert os.access(script, os.X_OK), script
        assert script.read_text().startswith("#!/usr/bin/env python3\n"), script
        assert (EXAMPLES / name / "README.md").is_file(), name


@pytest.mark.parametrize("name", NAMES)
def test_run_names_the_missing_file_and_exits_2(tmp_path, name):
    """Without the data: exit 2 and the missing file's path in the message, nothing fitted."""
    absent = tmp_path / "nowhere"
    done = run(name, tmp_path / "out", PENDFMU_REALDATA=str(absent))
    assert done.returncode == 2, done.stderr
    assert str(absent / name) in done.stderr
    assert not (tmp_path / "out" / "result.json").exists()


def test_run_started_by_any_python3_uses_the_projects_interpreter(tmp_path):
    """`run OUTDIR` as a user types it: the first python3 on PATH (here a bare interpreter
    without pendfmu's dependencies, where the machine has one) hands over to the project's
    .venv; the run then gets as far as the missing data (exit 2, the file named)."""
    import shutil

    bare = shutil.which("python3", path=os.defpath) or sys.executable
    absent = tmp_path / "nowhere"
    done = subprocess.run([bare, str(EXAMPLES / "kord-stk" / "run"), str(tmp_path / "out")], capture_output=True,
                          text=True, env={**os.environ, "PENDFMU_REALDATA": str(absent)}, timeout=120)
    assert done.returncode == 2, done.stderr
    assert str(absent / "kord-stk") in done.stderr, done.stderr


def test_run_refuses_an_outdir_git_could_commit(tmp_path):
    """The converted data are derived from files licensed for internal testing only: an
    OUTDIR inside the repository (other than the git-ignored out/) is refused, exit 2."""
    inside = EXAMPLES / "kord-stk" / "converted"
    done = run("kord-stk", inside)
    assert done.returncode == 2 and "inside the repository" in done.stderr, done.stderr
    assert not inside.exists()


_RUNS: dict[str, tuple[Path, subprocess.CompletedProcess]] = {}


def run_once(name: str, tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """One `run` per example and session, shared by the tests that read its output."""
    if name not in _RUNS:
        outdir = tmp_path_factory.mktemp(name)
        _RUNS[name] = (outdir, run(name, outdir))
    return _RUNS[name]


def example_output(name: str, tmp_path_factory):
    """(the example's convert module, its OUTDIR) after its one run of the session; skipped
    without the data."""
    convert = rd.load_example(name)
    if not rd.available(*convert.SOURCES):
        pytest.skip(f"real data absent: {', '.join(map(str, convert.SOURCES))}")
    outdir, done = run_once(name, tmp_path_factory)
    assert done.returncode == 0, done.stderr
    return convert, outdir


@pytest.mark.parametrize("name", running(NAMES))
def test_run_writes_the_result(tmp_path_factory, name):
    convert, tmp_path = example_output(name, tmp_path_factory)
    document = json.loads((tmp_path / "result.json").read_text())
    fitted = document["interval_method"]
    assert fitted, "no parameter fitted"
    assert all(math.isfinite(document["parameters"][label]) for label in fitted)
    stage = convert.STAGE if isinstance(convert.STAGE, str) else " ".join(map(str, convert.STAGE))
    first = "pendfmu system " if name == "EMPS" else f"pendfmu fit {stage} "
    assert (tmp_path / "command.txt").read_text().startswith(first)
    if name == "EMPS":
        check_emps(document)


def check_emps(document):
    """Issue 14's EMPS done-when, on the closed-loop run (examples/realdata/EMPS/run).

    Identification (DATA_EMPS, the loop fitted to encoder and controller output; measured
    M 94.87 kg, Fv 217.5 N s/m, Fc 19.36 N, offset -3.164 N): M within 5 % and the offset
    within 1 N of the published IDIM-LS values, as asked. Fv (+6.9 %) and Fc (-5.1 %) are
    not within 5 %, and the run measures why: the fitted friction differs from the
    published one by 0.55 N rms over the speeds the record visits (1.5 % of the friction's
    own rms: Fv and Fc trade against each other), and the published parameters, simulated
    the same way, give a larger output error on the identification record itself. The
    output-error optimum is not at the published parameters.

    Validation (DATA_EMPS_PULSES, closed loop with the authors' PD and gtau): the velocity
    and force errors no worse than the published 0.479 % and 8.94 % (measured 0.398 % and
    8.55 %), under the protocol the published model's own errors choose (its simulation here
    gives 0.402 % and 8.77 %, beside the maintainers' independent 0.401 % and 8.71 %); and
    no worse than the published parameters under every protocol."""
    b = document["benchmark"]
    published = b["published"]
    assert b["M"] == pytest.approx(published["M"], rel=0.05)
    assert abs(b["offset"] - published["offset"]) < 1.0
    assert b["friction_difference"]["rms"] < 0.02 * b["friction_difference"]["published_rms"]
    assert b["identification"]["fitted"]["force"] < b["identification"]["published"]["force"]
    assert b["identification"]["fitted"]["velocity"] < b["identification"]["published"]["velocity"]
    fitted = b["validation"]["fitted"]
    assert fitted["velocity"] <= b["published_errors"]["velocity"]
    assert fitted["force"] <= b["published_errors"]["force"]
    for protocol, errors in b["all_protocols"]["fitted"]["test"].items():
        reference = b["all_protocols"]["published"]["test"][protocol]
        assert errors["velocity"] <= reference["velocity"] and errors["force"] <= reference["force"], protocol


# ---------------------------------------------------------------- friction-identification

CARRIAGE = "friction-identification"
# The carriage's straight-line fit before v_Sc was freed (convert.build_line, seed 0):
# eta 0.9929, k_fwc 64.18 N s/m, F_Kc = F_Sc 33.59 N (F_Sc at its bound).
LINE = {"eta": 0.9929, "k_fwc": 64.18, "F_Kc": 33.59, "F_Sc": 33.59}


@pytest.mark.parametrize("extra", [
    {"F_Sc": 28.0, "F_Kc": 41.7, "k_fwc": 46.6, "v_Sc": 0.137},  # the carriage's fit: rising to F_K
    {"F_Sc": 3.0, "F_Kc": 1.0, "k_fwc": 2.0, "v_Sc": 0.05, "dk_fwc": 0.5, "dF_Kc": 0.2},  # falling, asymmetric
    {"F_Sc": 3.0, "F_Kc": 1.0, "k_fwc": 2.0},  # no Stribeck: the straight line
])
def test_the_examples_friction_law_is_the_cart_fmus(extra):
    """convert.sliding_friction, the example's own evaluation of friction.h's law, against the
    Cart FMU's friction force F_F at every sliding sample of a run forwards and backwards (a
    1 kg cart under a sine force of 3 (F_S + F_K), 0.5 s period, 2 s): the same formula, so
    the same numbers to rounding (measured difference below 1e-13 N)."""
    from pendfmu.simulator import ComponentFMU

    convert = rd.load_example(CARRIAGE)
    parameters = dict(m_c=1.0, m_p=0.0, eta=1.0, k_M=1.0, k_D=1.0, **extra)
    amplitude = 3.0 * (extra["F_Sc"] + extra["F_Kc"])
    times = np.linspace(0.0, 2.0, 4001)
    with ComponentFMU("Cart", parameters) as cart:
        run = cart.run(times, ["v", "F_F", "mode"], inputs=lambda t: {"I": amplitude * math.sin(4 * math.pi * t)})
    sliding = run["mode"] != 0
    assert np.count_nonzero(run["v"][sliding] > 0.01) > 500 and np.count_nonzero(run["v"][sliding] < -0.01) > 500
    expected = convert.sliding_friction(parameters, run["v"][sliding])
    assert np.max(np.abs(run["F_F"][sliding] - expected)) < 1e-9 * amplitude


def test_the_published_curve_is_the_papers_model():
    """convert.published_friction against SOURCE.txt's model worked by hand: 10 N at v -> 0,
    the hump's top c3 + c2 c4 at v = c4, the straight line c1 + c2 v once the hump has
    decayed (e^-48 at 0.66 m/s)."""
    convert = rd.load_example(CARRIAGE)
    assert convert.published_friction(np.array([1e-12]))[0] == pytest.approx(10.0)
    assert convert.published_friction(np.array([0.01352]))[0] == pytest.approx(29.63 + 67.44 * 0.01352)
    assert convert.published_friction(np.array([0.66]))[0] == pytest.approx(10.0 + 67.44 * 0.66)


def flat(tree: dict, prefix: str = "") -> dict:
    """A nested result's leaves, keyed by their path (pytest.approx takes flat mappings)."""
    leaves = {}
    for key, value in tree.items():
        leaves.update(flat(value, f"{prefix}{key}.") if isinstance(value, dict) else {prefix + key: value})
    return leaves


@pytest.fixture(scope="module")
def carriage_result(tmp_path_factory):
    convert, outdir = example_output(CARRIAGE, tmp_path_factory)
    return convert, json.loads((outdir / "result.json").read_text())


def test_carriage_stribeck_fit_is_physical_and_identified(carriage_result):
    """Issue 14: the fit frees v_Sc. Every parameter in its physical range with a finite
    interval, none at a search bound; the friction at v -> 0 (F_Sc 28.0 N) lies below the
    level far from zero speed (F_Kc 41.7 N): the curve rises, as the data-implied friction of
    the drive does (20 N in the lowest bin, 36 N at 0.075 m/s), and it is identified (its
    interval excludes F_Kc); v_Sc inside the measured speeds."""
    convert, document = carriage_result
    p, ci = document["parameters"], document["ci95"]
    assert set(document["interval_method"]) == {"eta", "k_fwc", "F_Kc", "F_Sc", "v_Sc"}
    assert not [flag for flags in document["flags"].values() for flag in flags if "bound" in flag]
    assert 0.9 < p["eta"] <= 1.0 and ci["eta"][1] <= 1.0
    assert all(ci[name][0] > 0 for name in ("k_fwc", "F_Kc", "F_Sc", "v_Sc"))
    assert ci["F_Sc"][1] < ci["F_Kc"][0]
    assert 0.003 < p["v_Sc"] < 0.66


def test_carriage_stribeck_curve_against_the_published_and_the_data(carriage_result):
    """The result's friction_comparison (convert.friction_comparison), recomputed here from
    the fitted parameters, and held to what the data say.

    * The data-implied friction of the drive (the force the fit sees, minus 24.7 kg a): the
      Stribeck curve follows it to 1.32 N rms (measured); the straight line to 2.98 N. Bound:
      2.0 N, between the two: a fit that fell back to a line fails.
    * The published curve against the load cell's data-implied friction (the authors' own
      force): 4.76 N rms measured; bound 6 N. This holds the data-implied friction (scale,
      filter, alignment) to the authors' result, independently of pendfmu's fit.
    * Fitted against published: 21.87 N rms, 26.07 N at most (the line: 21.69, 23.14). The
      Stribeck curve is not closer to the published one, and cannot be: the drive includes
      the drive train's friction before the load cell (drive minus load-cell implied friction:
      23.6 N rms over the bins, 5.7 N near rest to 39 N at the top speed). So the test holds
      the difference to that gap: within 3 N of it (measured 1.7 N; each curve's own misfit,
      1.3 and 4.8 N, bounds it by about 6 N)."""
    convert, document = carriage_result
    comparison = document["friction_comparison"]
    assert flat(comparison) == pytest.approx(flat(convert.friction_comparison(document["parameters"])))
    scope, load_cell = convert.read_servo_scope(), convert.read_load_cell()
    implied = convert.implied_friction(scope, load_cell)
    grid = convert.speed_grid(scope)
    fitted = convert.sliding_friction(document["parameters"], grid)
    assert comparison["fitted_minus_published"]["rms"] == pytest.approx(
        math.sqrt(np.mean((fitted - convert.published_friction(grid)) ** 2)))
    data = comparison["data_implied"]
    line = convert.friction_comparison(LINE, scope, load_cell)["data_implied"]["fitted_minus_drive"]["rms"]
    print(f"\ncarriage: fitted-published {comparison['fitted_minus_published']}, fitted-drive "
          f"{data['fitted_minus_drive']['rms']:.3f} (line {line:.3f}), published-load cell "
          f"{data['published_minus_load_cell']['rms']:.3f}")
    assert data["fitted_minus_drive"]["rms"] < 2.0 < line
    assert data["published_minus_load_cell"]["rms"] < 6.0
    gap = math.sqrt(np.mean((implied["drive"] - implied["load_cell"]) ** 2))
    assert abs(comparison["fitted_minus_published"]["rms"] - gap) < 3.0


# ---------------------------------------------------------------- rotary-inverted-pendulum

FURUTA = "rotary-inverted-pendulum"


@pytest.fixture(scope="module")
def furuta_result(tmp_path_factory):
    convert, outdir = example_output(FURUTA, tmp_path_factory)
    return convert, json.loads((outdir / "result.json").read_text())


def test_furuta_sensor_is_fitted_not_corrected_by_hand(furuta_result):
    """Issue 14: the conversion is the firmware's degrees in pendfmu's convention only
    (phi = pi + radians(printed)); the fit frees phi_offset and phi_scale, and no friction
    value or box is given (the data-derived box holds the friction). The scale comes out in
    the firmware's direction, > 1 (readings per true unit: 11.11/11 = 1.0101; measured
    1.0159), and the reading at hanging, phi_offset + pi (phi_scale - 1), is the encoder's
    zero (measured 0.22 deg). Nothing at a search bound."""
    convert, document = furuta_result
    assert not any(option.startswith(("k_fwp=", "T_Kp=", "T_Sp=")) for option in convert.OPTIONS)
    raw = convert.read_furuta_degrees()
    recording = convert.furuta_recording()
    start = int(round(recording.time[0] / convert.FURUTA_PERIOD))
    assert np.allclose(recording.signal("phi"), math.pi + np.radians(raw[start:start + len(recording.time)]))
    p = document["parameters"]
    assert set(document["interval_method"]) >= {"phi_offset", "phi_scale", "k_fwp", "T_Kp", "J_p"}
    assert 1.0 < p["phi_scale"] < 1.03 and convert.FIRMWARE_SCALE == pytest.approx(400 / 396)
    zero = p["phi_offset"] + math.pi * (p["phi_scale"] - 1)
    assert abs(math.degrees(zero)) < 1.0
    assert not [flag for flags in document["flags"].values() for flag in flags if flag.startswith("at ")]


def test_furuta_damping_against_the_published_figure(furuta_result):
    """The published 4.638e-4 is the authors' compute.py ratio with omega in deg/s: their
    procedure on this run's file gives 4.35e-4 (one of the three runs averaged), which
    confirms the reading; as a damping ratio it is 4.638e-4 * 180/pi = 0.0266. pendfmu's
    fitted model put through the same procedure: 4.08e-4 measured, held within 15 % of the
    run's own figure; the result file's comparison is what convert.published_comparison
    computes from its parameters."""
    convert, document = furuta_result
    comparison = document["published_comparison"]
    assert comparison["authors_method_this_run"]["sample_maxima"] == pytest.approx(4.35e-4, rel=0.01)
    assert comparison["published"]["damping_ratio"] == pytest.approx(4.638e-4 * 180 / math.pi)
    model = comparison["fitted_model"]
    low, high = model["ci95"]
    assert low < model["value"] < high
    assert abs(model["value"] / comparison["authors_method_this_run"]["refined_maxima"] - 1) < 0.15
    viscous = comparison["viscous_only"]["damping_ratio"]["value"]
    p = document["parameters"]
    assert viscous == pytest.approx(p["k_fwp"] / (2 * math.sqrt(p["J_p"] * p["m_p"] * p.get("g", 9.81) * p["l"])))
    again = convert.published_comparison(document)
    assert again["fitted_model"]["value"] == pytest.approx(model["value"], rel=1e-9)


# ---------------------------------------------------------------- physical-cartpole

CARTPOLE = "physical-cartpole"


@pytest.fixture(scope="module")
def cartpole(tmp_path_factory):
    convert, outdir = example_output(CARTPOLE, tmp_path_factory)
    return (convert, json.loads((outdir / "result.json").read_text()),
            json.loads((outdir / "pendulum.json").read_text()))


def test_cartpole_conversion_decisions():
    """The conversion's decisions, measured on the log (convert.py's docstring): the
    command is the next row's Q, phi is minus the angle (the a-term of the angle's
    acceleration has the driver's sign, + a cos(angle), and with the gravity term gives
    g within 6 % from splines of 21 ms readings: measured 10.31), frozen rows are missing
    angles, and the firmware adds to Q a compensation in the direction of the last speed
    (measured: duty = 0.502 Q + 0.034 sgn(v_prev) - 0.009, 7 PWM counts rms)."""
    convert = rd.load_example(CARTPOLE)
    if not rd.available(*convert.SOURCES):
        pytest.skip("real data absent")
    log = convert.read_log()
    convert.check_log(log)
    cart = convert.cart_recording(log)
    assert np.array_equal(cart.signal("u"), log.columns["Q"][1:])
    assert np.array_equal(cart.time, log.columns["time"][:-1])
    law = convert.pwm_law(log)
    assert law["gain"] == pytest.approx(0.502, abs=0.002) and law["compensation"] == pytest.approx(0.034, abs=0.003)
    assert law["rms_counts"] < 10
    sign = convert.angle_sign(log)
    assert sign["acceleration_term"] > 0 and sign["g_implied"] == pytest.approx(9.81, rel=0.06)
    pendulum = convert.pendulum_recording(log)
    assert np.array_equal(np.isnan(pendulum.signal("phi")), log.columns["frozen"] == 1)
    assert pendulum.signal("phi")[0] == pytest.approx(math.pi, abs=0.01)  # hanging at the start: phi = pi
    assert convert.angle_outliers(log) < 8  # invalid_steps rows lie on the swing (measured 5.8 counts)


@pytest.mark.acceptance
def test_cartpole_the_motion_fixes_ratios_not_the_mass(cartpole):
    """With m_c free, it and k_u (and k_fwc) move together (correlation > 0.999) and m_c's
    95 % interval spans many decades around the published 2.82 kg. Over the profile (m_c
    fixed from 2 to 20 kg, the rest refitted) k_u changes ten-fold but k_u/M and k_fwc/M
    by 5.5 % (measured 11.51 -> 10.91 and 21.53 -> 20.48 m/s^2, 1/s); leaving the pole's
    reaction out (m_p = 0) moves them by under 4 % (measured 3.7 %). The pole's reaction
    only bounds the mass from below: lighter than ~0.8 kg, its reaction would show
    (the likelihood-ratio threshold over the residuals' ~18 independent samples)."""
    convert, result, _ = cartpole
    mass = result["mass_evidence"]
    free = mass["free"]
    assert free["correlation_m_c_k_u"] > 0.999 and free["correlation_m_c_k_fwc"] > 0.999
    low, high = free["ci95"]
    assert low < convert.PUBLISHED["m_cart_eff"] < high and high / low > 100
    heavy = [point for point in mass["profile"] if 2.0 <= point["m_c"] <= 20.0]
    for key in ("k_u/M", "k_fwc/M"):
        values = [point[key] for point in heavy]
        assert max(values) / min(values) < 1.07, (key, values)
    at = next(point for point in mass["profile"] if point["m_c"] == convert.PUBLISHED["m_cart_eff"])
    assert mass["no_pole"]["k_u/M"] == pytest.approx(at["k_u/M"], rel=0.05)
    assert mass["no_pole"]["k_fwc/M"] == pytest.approx(at["k_fwc/M"], rel=0.05)
    assert 0.5 < mass["lower_bound"] < convert.PUBLISHED["m_cart_eff"]


@pytest.mark.acceptance
def test_cartpole_cart_against_the_published(cartpole):
    """The cart at the published mass: k_u = 32.8 N, k_fwc = 61.4 N s/m, delay 26.9 ms
    (measured). Their Jacobian intervals assume white residuals; these drift (110 times the
    encoder's noise, ~18 independent values in 749), so the honest interval of a ratio is the
    spread over the eleven pieces fitted each with its own k_u and k_fwc: the mean's
    95 % t-interval (measured k_u/M [8.74, 11.81] m/s^2, k_fwc/M [15.9, 22.6] 1/s). The joint
    fit lies inside it; the published 7.46 and 12.66 (21.7 N and 36.8 N s/m over
    M = 2.907 kg) lie below it, 1.5 and 1.7 times smaller than the joint fit, while the
    terminal speed k_u/k_fwc = 0.534 m/s is within 10 % of the published v_max 0.59. The
    delay trades with the gains (correlation 0.96): 26.9 ms jointly, 16.4 ms with the gains
    per piece; both lie inside the firmware's latency column (5-95 %: 14.4-34.8 ms)."""
    convert, result, _ = cartpole
    c = result["published_comparison"]
    assert c["terminal_speed_m_per_s"]["fitted"] == pytest.approx(convert.PUBLISHED["v_max"], rel=0.12)
    for key, factor in (("acceleration_per_command_m_per_s2", 1.51), ("damping_per_mass_1_per_s", 1.67)):
        low, high = c[key]["pieces_mean_ci95"]
        assert low < c[key]["fitted"] < high, key
        assert c[key]["published"] < low, key
        assert c[key]["fitted"] / c[key]["published"] == pytest.approx(factor, rel=0.05), key
    delay = c["delay_s"]
    low, high = delay["latency_column_p5_p95"]
    assert low <= delay["fitted"] <= high and low <= delay["with_gains_per_piece"] <= high
    assert result["parameters"]["F_Kc"] < 2.0  # small: the firmware compensates most of it


@pytest.mark.acceptance
def test_cartpole_pendulum_against_the_published(cartpole):
    """The swing-up's five 0.5 s pieces: the published pole (0.395 m, 0.087 kg, a uniform rod)
    fits the swing, J_p within 1 % of the rod's 4.525e-3 kg m^2 (measured 4.5252e-3, its
    Jacobian interval +-0.4 %); the damping k_fwp = 4.8e-4 N m s is 9.6 times the published
    J_fric = 5e-5, which lies far outside its interval (Jacobian: [4.4e-4, 5.3e-4]; the
    variants with phi_offset, J_p, T_Kp or a delay free or fixed gave 4.3e-4 to 4.8e-4)."""
    convert, result, pendulum = cartpole
    c = result["published_comparison"]
    assert c["pendulum_inertia_kg_m2"]["fitted"] == pytest.approx(c["pendulum_inertia_kg_m2"]["published"], rel=0.01)
    low, high = c["pendulum_damping_N_m_s"]["ci95"]
    assert 3e-4 < low < c["pendulum_damping_N_m_s"]["fitted"] < high < 7e-4
    assert low > 4 * convert.PUBLISHED["J_fric"]
    assert abs(pendulum["parameters"]["phi_offset"]) < 0.02  # the potentiometer's zero: within about a degree


@pytest.mark.parametrize("name", running(n for n in NAMES if n not in ("kord-stk",)))
def test_the_verdict_and_intervals_pass_a_split_window_test(tmp_path_factory, name):
    """Issue 25's done-when on every long real recording: the early and the late halves of the
    recordings, fitted by the tool as the example fits the whole (the fit's own validation,
    recorded in the result: fitting/validation.py), give for each fitted parameter estimates
    that differ by no more than their combined 95 % interval, or the whole record's result
    marks it model-inadequate or not-separately-identified, and its interval holds both. (The
    halves are read from the result rather than fitted again here: the same fits, twice the
    run time. kord-stk's current steps are a few hundred samples: no halves.) A half that
    could not start where its recording is fails this: EMPS's late half once began at the
    file's first position (its initial state held for every window) and widened M's interval
    to [76.3, 95.2] kg."""
    convert, outdir = example_output(name, tmp_path_factory)
    whole = json.loads((outdir / "result.json").read_text())
    windows = whole["fit"]["assessment"].get("windows", {})
    assert "note" not in windows, windows["note"]  # a long recording whose halves could not be used
    if not windows.get("halves"):
        pytest.skip(f"{name}: no recording long enough to split")
    if whole["fit"]["assessment"]["verdict"] != "adequate":
        assert windows["method"] == "fits of the halves"  # fitted as the whole was, not only refitted locally
    marks = {"model-inadequate", "not-separately-identified"}
    unmarked = []
    for label in whole["interval_method"]:
        early, late = windows["halves"]["early"].get(label), windows["halves"]["late"].get(label)
        if early is None or late is None or None in early or None in late:
            continue
        combined = math.hypot((early[2] - early[1]) / 2, (late[2] - late[1]) / 2)
        if abs(early[0] - late[0]) <= combined:
            continue
        low, high = whole["ci95"][label]
        held = low <= min(early[0], late[0]) and max(early[0], late[0]) <= high
        if not (marks & set(whole.get("flag_kinds", {}).get(label, [])) and held):
            unmarked.append(f"{label}: early {early}, late {late}, whole {whole['ci95'][label]}")
    assert unmarked == [], unmarked
