"""Every `pendfmu fit` option against every kind of target: applied, as the result's
provenance records the fit, or refused before any work with exit 2 (issue 23).

`fit all` once dropped --fix and --bounds while recording them as applied; a stage's --fix
of a name it did not fit was silently nothing. Here each option is run on each target --
the three stages, `all`, a user's FMU (--fmu) and an SSP system (--system) -- and the
provenance's record of what was fitted (not of what was asked) must show the option's
effect; where an option cannot apply, the command must stop with exit 2 naming the option,
before writing anything. The recordings are short and the global search tiny so that the
hundred-odd fits stay cheap; the options' numerical effects are tested elsewhere.

Run controls that are not part of what is fitted (--out, --report, --checkpoint, --resume,
--strict) are tested at the end and in test_interrupt.py and test_warnings.py; --scheduler
(a Dask cluster) in test_distributed.py.
"""

from __future__ import annotations

import json
import math

import pytest

from pendfmu.cli import main
from pendfmu.virtual_rig import Trial, steps, write_experiments

# Every fit here: a global search of 2 generations of 2 candidates per parameter, Jacobian
# intervals, in this process (--workers 1: a pool of worker processes cost these small fits a
# third of their CPU time to start). An option BASE also sets is tested without BASE's word.
SEARCH = ["--generations", "2", "--population", "2"]
INTERVALS = ["--uncertainty", "jacobian"]
IN_PROCESS = ["--workers", "1"]
BASE = SEARCH + INTERVALS + IN_PROCESS
BASE_WITHOUT = {"uncertainty": SEARCH + IN_PROCESS, "no-global": INTERVALS + IN_PROCESS,
                "workers": SEARCH + INTERVALS}
TARGETS = ("current", "cart", "pendulum", "all", "fmu", "system")


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    """A short recording per stage (a folder `all` sorts), a foreign FMU with one recording,
    and an SSP system of CurrentLoop and Cart; the command-line words of each target."""
    from foreign.build import build
    from foreign.recordings import write_recordings

    root = tmp_path_factory.mktemp("fit-options")
    rig = root / "rig"
    experiments = [
        Trial("current-steps", "current", 0.008, 20e-6, ("I_c", "I"), steps((0, 0.0), (1e-3, 2.0), (5e-3, -1.0))),
        Trial("cart-startup", "cart", 0.4, 2e-4, ("I_c", "I", "x", "v"), steps((0, 0.0), (0.02, 3.0), (0.2, 0.0)),
                   sidecar_parameters={"m_p": 0.0}, known_initial=("x", "v")),
        Trial("pendulum-decay", "pendulum", 0.8, 2e-4, ("a", "phi", "w"), lambda t: 0.0,
                   truth_overrides={"phi0": math.pi + 0.4, "w0": 0.0}, known_initial=("w",)),
    ]
    write_experiments(rig, {}, seed=3, experiments=experiments)
    fmu = build("ForeignCart", root)
    recordings = write_recordings(fmu, root / "foreign")
    (root / "start.json").write_text(json.dumps({"parameters": {"m": 2.0, "k_u": 5.0, "c_v": 6.0}}))
    ssp = root / "cart.ssp"
    assert main(["system", "--out", str(ssp), "--component", "CurrentLoop", "Cart",
                 "--connect", "CurrentLoop.I_mean=Cart.I"]) == 0
    words = {
        "current": ["current", str(rig / "current-steps.csv")],
        "cart": ["cart", str(rig / "cart-startup.csv")],
        "pendulum": ["pendulum", str(rig / "pendulum-decay.csv")],
        "all": ["all", str(rig)],
        "fmu": ["--fmu", str(fmu), str(recordings["fit_steps"]), "--free", "k_u", "c_v", "--params",
                str(root / "start.json")],
        "system": ["--system", str(ssp), str(rig / "cart-startup.csv"), "--free", "Cart.k_fwc", "Cart.F_Kc"],
    }
    return root, words


def fit(setup, target, extra, tmp_path, capsys, base=BASE):
    """Run `pendfmu fit` on a target with extra options: (exit code, the result's
    provenance or None, stderr)."""
    _, words = setup
    out = tmp_path / f"{target}.json"
    code = main(["fit", *words[target], *base, *extra, "--out", str(out)])
    err = capsys.readouterr().err
    provenance = json.loads(out.read_text())["provenance"] if code == 0 else None
    if code != 0:
        assert not out.exists(), "a refused fit wrote its result"
    return code, provenance, err


def stages(provenance):
    return list(provenance["stages"].values())


def recordings_of(provenance):
    return [r for stage in stages(provenance) for r in stage["recordings"].values()]


def any_stage(provenance, check) -> bool:
    return any(check(stage) for stage in stages(provenance))


# option -> target -> (extra words, check of the provenance) or None: refused with exit 2.
CASES = {
    "params": {
        "current": (["--params", "{rig}/p.json"], lambda p: any_stage(p, lambda s: s["fixed"].get("k_M") == 0.061)),
        "cart": (["--params", "{rig}/p.json"], lambda p: any_stage(p, lambda s: s["fixed"].get("k_M") == 0.061)),
        "pendulum": (["--params", "{rig}/p.json"], lambda p: any_stage(p, lambda s: s["fixed"].get("g") == 9.80)),
        "all": (["--params", "{rig}/p.json"], lambda p: all(s["fixed"].get("k_M") == 0.061 for s in stages(p)
                                                             if "k_M" in s["fixed"])),
        "fmu": (["--params", "{root}/start2.json"], lambda p: any_stage(p, lambda s: s["fixed"]["m"] == 2.1)),
        "system": (["--params", "{root}/system.json"],
                   lambda p: any_stage(p, lambda s: s["fixed"].get("Cart.m_c") == 3.1)),
    },
    "seed": {target: (["--seed", "7"], lambda p: all(s["seed"] == 7 for s in stages(p))) for target in TARGETS},
    "free": {
        "current": (["--free", "a_h"], lambda p: any_stage(p, lambda s: "a_h" in s["free"])),
        "cart": (["--free", "m_c"], lambda p: any_stage(p, lambda s: "m_c" in s["free"])),
        "pendulum": (["--free", "J_p"], lambda p: any_stage(p, lambda s: "J_p" in s["free"])),
        "all": (["--free", "m_c"], lambda p: p["stages"]["cart"]["free"].count("m_c") == 1
                and "m_c" not in p["stages"]["pendulum"]["free"]),
        "fmu": (["--free", "F_c"], lambda p: any_stage(p, lambda s: "F_c" in s["free"])),
        "system": (["--free", "Cart.eta"], lambda p: any_stage(p, lambda s: "Cart.eta" in s["free"])),
    },
    "fix": {
        "current": (["--fix", "dIdt_max"], lambda p: any_stage(p, lambda s: "dIdt_max" not in s["free"]
                                                               and "dIdt_max" in s["fixed"])),
        "cart": (["--fix", "eta"], lambda p: any_stage(p, lambda s: "eta" not in s["free"] and "eta" in s["fixed"])),
        "pendulum": (["--fix", "T_Sp"], lambda p: any_stage(p, lambda s: "T_Sp" not in s["free"])),
        "all": (["--fix", "eta"], lambda p: "eta" not in p["stages"]["cart"]["free"]
                and p["stages"]["cart"]["fixed"]["eta"] == 0.4),
        "fmu": (["--fix", "c_v"], lambda p: any_stage(p, lambda s: "c_v" not in s["free"] and s["fixed"]["c_v"] == 6)),
        "system": (["--fix", "Cart.F_Kc"], lambda p: any_stage(p, lambda s: "Cart.F_Kc" not in s["free"])),
    },
    "bounds": {
        "current": (["--bounds", "T_i=1e-4:1e-3"], lambda p: any_stage(p, lambda s: s["bounds"]["T_i"] == [1e-4, 1e-3])),
        "cart": (["--bounds", "k_fwc=1:100"], lambda p: any_stage(p, lambda s: s["bounds"]["k_fwc"] == [1, 100])),
        "pendulum": (["--bounds", "k_fwp=1e-5:1e-2"],
                     lambda p: any_stage(p, lambda s: s["bounds"]["k_fwp"] == [1e-5, 1e-2])),
        "all": (["--bounds", "k_fwc=1:100"], lambda p: p["stages"]["cart"]["bounds"]["k_fwc"] == [1, 100]),
        "fmu": (["--bounds", "k_u=1:10"], lambda p: any_stage(p, lambda s: s["bounds"]["k_u"] == [1, 10])),
        "system": (["--bounds", "Cart.k_fwc=1:100"],
                   lambda p: any_stage(p, lambda s: s["bounds"]["Cart.k_fwc"] == [1, 100])),
    },
    "drive": {
        "current": (["--drive", "I_c"], lambda p: all(r["drives"] == {"CurrentLoop.I_c": ["I_c", "hold"]}
                                                      or r["drives"] == {"I_c": ["I_c", "hold"]}
                                                      for r in recordings_of(p))),
        "cart": (["--drive", "I"], lambda p: all(r["drives"] == {"I": ["I", "linear"]} for r in recordings_of(p))),
        "pendulum": (["--drive", "a"], lambda p: all(r["drives"] == {"a": ["a", "linear"]} for r in recordings_of(p))),
        "all": (["--drive", "I"], lambda p: all(r["drives"] == {"I": ["I", "linear"]}
                                                for r in p["stages"]["cart"]["recordings"].values())),
        "fmu": (["--drive", "u"], lambda p: all(r["drives"] == {"u": ["u", "hold"]} for r in recordings_of(p))),
        "system": (["--drive", "I_c"], lambda p: all(r["drives"] == {"I_c": ["I_c", "hold"]}
                                                     for r in recordings_of(p))),
    },
    "match": {  # a stage compares its recorded rate as well (the current stage has none; `all` refuses)
        "current": None,
        "cart": (["--match", "v"], lambda p: all(r["match"] == {"x": "x", "v": "v"} for r in recordings_of(p))),
        "pendulum": (["--match", "w"], lambda p: all(r["match"] == {"phi": "phi", "w": "w"}
                                                     for r in recordings_of(p))),
        "all": None,
        "fmu": (["--match", "x"], lambda p: all(r["match"] == {"x": "x"} for r in recordings_of(p))),
        "system": (["--match", "x"], lambda p: all(r["match"] == {"x": "x"} for r in recordings_of(p))),
    },
    "initial": {
        **dict.fromkeys(("current", "cart", "pendulum", "all")),
        "fmu": (["--initial", "x'=v0"], lambda p: all(["v0", "x'"] in r["starts"] for r in recordings_of(p))),
        "system": (["--initial", "x'=Cart.v0"], lambda p: all(["Cart.v0", "x'"] in r["starts"]
                                                              for r in recordings_of(p))),
    },
    "interpolation": {
        **dict.fromkeys(("current", "cart", "pendulum", "all")),
        "fmu": None,  # ForeignCart cannot interpolate its inputs (canInterpolateInputs false)
        "system": (["--interpolation", "linear"], lambda p: all(r["drives"]["I_c"] == ["I_c", "linear"]
                                                                for r in recordings_of(p))),
    },
    "per-recording": {
        "current": (["--per-recording", "I0"], lambda p: any_stage(p, lambda s: "I0[current-steps]" in s["free"])),
        "cart": (["--per-recording", "m_c"], lambda p: any_stage(p, lambda s: "m_c[cart-startup]" in s["free"])),
        "pendulum": (["--per-recording", "w0"], lambda p: any_stage(p, lambda s: "w0[pendulum-decay]" in s["free"])),
        "all": (["--per-recording", "w0"], lambda p: "w0[pendulum-decay]" in p["stages"]["pendulum"]["free"]),
        "fmu": (["--per-recording", "m"], lambda p: any_stage(p, lambda s: any(f.startswith("m[")
                                                                                 for f in s["free"]))),
        "system": (["--per-recording", "Cart.m_c"], lambda p: any_stage(p, lambda s: "Cart.m_c[cart-startup]"
                                                                          in s["free"])),
    },
    "window": {
        "current": (["--window", "0:0.004"], lambda p: all(r["span"][1] <= 0.004 for r in recordings_of(p))),
        "cart": (["--window", "0:0.3"], lambda p: all(r["span"][1] <= 0.3 for r in recordings_of(p))),
        "pendulum": (["--window", "0:0.6"], lambda p: all(r["span"][1] <= 0.6 for r in recordings_of(p))),
        "all": None,
        "fmu": (["--window", "0:1"], lambda p: all(r["span"][1] <= 1 for r in recordings_of(p))),
        "system": (["--window", "0:0.3"], lambda p: all(r["span"][1] <= 0.3 for r in recordings_of(p))),
    },
    "segment": {
        "current": (["--segment", "0.004"], lambda p: len(recordings_of(p)) == 2),
        "cart": (["--segment", "0.2"], lambda p: len(recordings_of(p)) == 2),
        "pendulum": (["--segment", "0.4"], lambda p: len(recordings_of(p)) == 2),
        "all": None,
        "fmu": (["--segment", "1"], lambda p: len(recordings_of(p)) > 1),
        "system": (["--segment", "0.2"], lambda p: len(recordings_of(p)) == 2),
    },
    "start": {  # with a window that starts late: its initial states measured, not estimated
        "current": (["--window", "0.002:0.006", "--start", "measured"],
                    lambda p: all(r["estimated"] == [] for r in recordings_of(p))),
        "cart": (["--window", "0.01:0.3", "--start", "measured"],
                 lambda p: all(r["estimated"] == [] for r in recordings_of(p))),
        "pendulum": (["--window", "0.2:0.6", "--start", "measured"],
                     lambda p: all("phi0" not in r["estimated"] for r in recordings_of(p))),
        "all": None,
        "fmu": (["--window", "0.5:1.5", "--start", "measured"],
                lambda p: all("x0" not in r["estimated"] for r in recordings_of(p))),
        "system": None,  # its initial states are Cart.x0, which no signal names by the x0 convention
    },
    "cost": {target: (["--cost", "quantized"], lambda p: all(s["cost"] == "quantized" for s in stages(p)))
             for target in TARGETS},
    "harmonic": {
        "current": (["--harmonic", "off"], lambda p: p["stages"]["current"]["harmonic"] == "off"),
        "all": (["--harmonic", "off"], lambda p: p["stages"]["current"]["harmonic"] == "off"),
        **dict.fromkeys(("cart", "pendulum", "fmu", "system")),
    },
    "no-global": {target: (["--no-global"], lambda p: not any(s["search"]["global"] for s in stages(p)))
                  for target in TARGETS},
    "workers": {target: (["--workers", "1"], lambda p: all(s["search"]["workers"] == 1 for s in stages(p)))
                for target in TARGETS},
    "generations": {target: (["--generations", "3"], lambda p: all(s["search"]["maxiter"] == 3 for s in stages(p)))
                    for target in TARGETS},
    "population": {target: (["--population", "3"], lambda p: all(s["search"]["popsize"] == 3 for s in stages(p)))
                   for target in TARGETS},
    "uncertainty": {target: (["--uncertainty", "bootstrap", "--replicates", "8"],
                             lambda p: all(s["uncertainty"] == {"method": "bootstrap", "replicates": 8}
                                           for s in stages(p)))
                    for target in TARGETS},
    "replicates": dict.fromkeys(TARGETS),  # with BASE's Jacobian intervals a replicate count applies to nothing
}


def _words(setup, extra):
    root, _ = setup
    return [w.format(rig=root / "rig", root=root) for w in extra]


@pytest.fixture(scope="module")
def parameter_files(setup):
    root, _ = setup
    (root / "rig" / "p.json").write_text(json.dumps({"parameters": {"k_M": 0.061, "g": 9.80}}))
    (root / "start2.json").write_text(json.dumps({"parameters": {"m": 2.1, "k_u": 5.0, "c_v": 6.0}}))
    (root / "system.json").write_text(json.dumps({"parameters": {"Cart.m_c": 3.1}}))


REFUSAL_WORDS = {"match": ["--match", "x"], "initial": ["--initial", "x=x0"], "interpolation": ["--interpolation",
                 "linear"], "window": ["--window", "0:0.1"], "segment": ["--segment", "0.1"],
                 "start": ["--start", "measured"], "harmonic": ["--harmonic", "off"], "replicates": ["--replicates", "8"]}


@pytest.mark.parametrize("option", list(CASES))
@pytest.mark.parametrize("target", TARGETS)
def test_each_option_applies_or_is_refused(setup, parameter_files, option, target, tmp_path, capsys):
    case = CASES[option][target]
    if case is None:
        code, provenance, err = fit(setup, target, REFUSAL_WORDS[option], tmp_path, capsys)
        assert code == 2, f"{option} on {target}: exit {code}\n{err}"
        assert f"--{option}" in err or option in err, err
        return
    words, check = case
    base = BASE_WITHOUT.get(option, BASE)
    code, provenance, err = fit(setup, target, _words(setup, words), tmp_path, capsys, base=base)
    assert code == 0, f"{option} on {target}: exit {code}\n{err}"
    assert check(provenance), f"{option} on {target}: not applied; provenance stages: {provenance['stages']}"


def test_fit_all_fits_what_it_says(setup, tmp_path, capsys):
    """The issue's example: `fit all rec --fix eta --bounds k_fwc=1:100` kept eta and searched
    k_fwc in [1, 100] (before, it fitted eta and searched [3, 300] while the provenance listed
    both options); the cart's estimate lies in the box."""
    code, provenance, err = fit(setup, "all", ["--fix", "eta", "--bounds", "k_fwc=1:100"], tmp_path, capsys)
    assert code == 0, err
    cart = provenance["stages"]["cart"]
    assert "eta" not in cart["free"] and cart["fixed"]["eta"] == 0.4
    assert cart["bounds"]["k_fwc"] == [1, 100]
    result = json.loads((tmp_path / "all.json").read_text())
    assert 1 <= result["parameters"]["k_fwc"] <= 100 and result["parameters"]["eta"] == 0.4


@pytest.mark.parametrize("words, message", [
    (["--fix", "m_p"], "does not fit 'm_p'"),  # the cart and the pendulum have m_p, neither fits it
    (["--free", "k_fw"], "'k_fw' is not a parameter any stage"),
    (["--bounds", "T_Kc=1:2"], "'T_Kc' is not a parameter any stage"),
    (["--drive", "phi"], "drives none of the stages"),
])
def test_fit_all_refuses_a_name_no_stage_takes_before_any_work(setup, words, message, tmp_path, capsys):
    code, _, err = fit(setup, "all", words, tmp_path, capsys)
    assert code == 2 and message in err, err
    assert "fit all: skipped" not in err


def test_a_stage_refuses_to_fix_what_it_does_not_fit(setup, tmp_path, capsys):
    code, _, err = fit(setup, "cart", ["--fix", "m_c"], tmp_path, capsys)
    assert code == 2 and "--fix: the cart stage does not fit 'm_c'" in err, err


def test_the_seed_of_a_switched_off_search_is_refused(setup, tmp_path, capsys):
    code, _, err = fit(setup, "current", ["--no-global", "--seed", "3"], tmp_path, capsys)
    assert code == 2 and "--seed: seeds the global search" in err, err


def test_run_controls_do_their_job(setup, tmp_path, capsys):
    """--report writes the page, --checkpoint names the file an interrupt would write (gone
    after a complete fit), --strict turns a warning into exit 3 with the result written."""
    report, checkpoint = tmp_path / "report", tmp_path / "c.checkpoint"
    code, provenance, err = fit(setup, "current", ["--report", str(report), "--checkpoint", str(checkpoint)],
                                tmp_path, capsys)
    assert code == 0 and (report / "index.html").is_file() and not checkpoint.exists()
    assert provenance["command"][-2:] == ["--out", str(tmp_path / "current.json")]


API_KEYWORDS = {"seed": 5, "uncertainty": "jacobian", "cost": "quantized"}


def api_arguments(setup, target):
    """The API's call for a target's command-line words: the same request."""
    from pendfmu.fitting.optimizer import GlobalOptions

    root, words = setup
    search = GlobalOptions(popsize=2, maxiter=2, workers=1)  # BASE's --workers 1
    if target == "fmu":
        return (str(root / "ForeignCart.fmu"), [words["fmu"][2]]), dict(free=["k_u", "c_v"],
                                                                       params=str(root / "start.json"),
                                                                       global_search=search, **API_KEYWORDS)
    return (target, words[target][1:]), dict(global_search=search, **API_KEYWORDS)


@pytest.mark.parametrize("target", ["current", "cart", "pendulum", "fmu"])
def test_the_command_line_and_the_api_fit_the_same_problem_to_the_bit(setup, target, tmp_path, capsys):
    """`pendfmu fit` and `pendfmu.fit` with the same request give the same result, bit for
    bit: both build one FitSpec (before, the command line fitted the current stage's ripple
    and the API did not, and `fit --fmu` lost the model's file and hash)."""
    from pendfmu.fitting.identification import fit as api_fit

    code, provenance, err = fit(setup, target, ["--seed", "5", "--cost", "quantized"], tmp_path, capsys)
    assert code == 0, err
    written = json.loads((tmp_path / f"{target}.json").read_text())
    positional, keywords = api_arguments(setup, target)
    result = api_fit(*positional, progress=False, **keywords)
    from_api = json.loads(json.dumps(result.to_dict(), default=float))
    for key in ("parameters", "stderr", "ci95", "interval_method", "correlation", "flags", "initial"):
        assert from_api[key] == written[key], key
    for key in ("stage", "cost", "nrmse", "nfev", "notes", "model"):
        assert from_api["fit"].get(key) == written["fit"].get(key), key
    assert from_api["provenance"]["stages"] == provenance["stages"]
    if target == "fmu":
        model = [entry for entry in provenance["inputs"] if entry["path"].endswith("ForeignCart.fmu")]
        assert written["fit"]["model"].endswith("ForeignCart.fmu") and model and model[0]["sha256"]
