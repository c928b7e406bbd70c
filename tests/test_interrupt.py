"""Ctrl-C during a fit (issue 7): the best values so far and a checkpoint are written, and
`--resume` ends at the same result, to the bit, as a fit that was never interrupted,
without repeating the simulations done before the interrupt."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys


from conftest import CART_TRUTH, result_without_time
from processes import busy_workers

from pendfmu.cli import main
from pendfmu.virtual_rig import Trial, steps, write_experiments


def cart_experiment(name, duration, current):
    return Trial(name, "cart", duration, 2e-4, ("I_c", "I", "x"),
                      steps((0, 0.0), (0.02, current), (duration * 0.6, 0.0)),
                      sidecar_parameters={"m_p": 0.0}, known_initial=("x", "v"))


def test_interrupt_writes_best_so_far_and_resume_matches_an_uninterrupted_fit(cart_recording, tmp_path,
                                                                                 interrupt_costs):
    command = ["fit", "cart", str(cart_recording), "--seed", "8", "--workers", "1"]
    calls = interrupt_costs
    assert main(command + ["--out", str(tmp_path / "straight.json")]) == 0
    straight_calls = calls["n"]

    calls.update(n=0, stop_at=40)
    out = tmp_path / "fit.json"
    assert main(command + ["--out", str(out)]) == 130
    best = json.loads(out.read_text())
    assert "interrupted" in best and set(best["parameters"]) >= {"eta", "k_fwc", "F_Kc", "F_Sc"}
    checkpoint = tmp_path / "fit.json.checkpoint"
    assert checkpoint.exists()

    calls.update(n=0, stop_at=None)
    assert main(command + ["--out", str(out), "--resume"]) == 0
    assert result_without_time(out) == result_without_time(tmp_path / "straight.json")
    assert calls["n"] == straight_calls - 39  # the 39 finished simulations were looked up, not repeated
    assert not checkpoint.exists()  # a completed fit removes its checkpoint


def test_resume_refuses_a_checkpoint_of_another_fit(cart_recording, tmp_path, capsys):
    checkpoint = tmp_path / "other.checkpoint"
    checkpoint.write_text(json.dumps({"pendfmu_checkpoint": 1, "fingerprint": "another", "costs": {}}))
    code = main(["fit", "cart", str(cart_recording), "--out", str(tmp_path / "o.json"), "--checkpoint", str(checkpoint),
                 "--resume"])
    assert code == 2 and "belongs to another fit" in capsys.readouterr().err


def test_a_real_sigint_stops_worker_processes_and_writes_the_checkpoint(tmp_path):
    # 20 s of recording: the fit takes about 15 s, nearly all global search, so the signal at 4 s lands inside
    # it (a 3 s recording is fitted whole in under 5 s since the cart steps exactly)
    write_experiments(tmp_path, CART_TRUTH, seed=9, experiments=[cart_experiment("long", 20.0, 2.5)])
    out = tmp_path / "fit.json"
    process = subprocess.Popen([sys.executable, "-m", "pendfmu", "fit", "cart", str(tmp_path / "long.csv"),
                                "--out", str(out), "--workers", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    busy_workers(process)  # inside the global search, both workers computing: not after a fixed sleep, which a
    process.send_signal(signal.SIGINT)  # first start on a loaded machine outlasted (interrupted before the fit began)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    assert "interrupted" in stdout and (tmp_path / "fit.json.checkpoint").exists()
    assert "interrupted" in json.loads(out.read_text())
