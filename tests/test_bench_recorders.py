"""The benchmarks' problem recorders (the controller's on_solve hook) on short closed loops."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).parent.parent / "bench"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, BENCH / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_min_violation_recorder_records_replayable_problems() -> None:
    """bench/min_violation_stop.py's recorder on the demo's first 0.3 s (wall-headon, seed 0, where
    the braking rollout cannot certify F, so the certificate solves its minimum-violation problem):
    it records at least one problem, each with the run's state, bounds and a primal start of the
    problem's size, and replaying one gives a verdict. Oracle: the problem's own layout (its
    variables' bounds have the start's length)."""
    bench = _load("min_violation_stop")
    calls = bench._record_run("wall-headon:0", duration=0.3)
    assert calls and all(c["run"] == "wall-headon:0" for c in calls)
    c = calls[0]
    assert c["h0"].shape == c["h_ref"].shape and np.all(c["lo"] <= c["hi"]) and np.all(np.isfinite(c["guess"]))


@pytest.mark.slow
def test_mode3_recorder_records_mode_three_problems() -> None:
    """bench/mode3_solvers.py's recorder on the demo's first 0.8 s (Mode III comes within 0.5 s):
    every recorded problem is a Mode III one (its contact plane is the wall, index 0 of the scene),
    with a primal start, input bounds and the options of the model the controller planned on (the
    replay's model)."""
    bench = _load("mode3_solvers")
    from dataclasses import asdict, replace

    import validation.scenarios as scenarios

    original = scenarios.SCENARIOS["wall-headon"]
    calls = bench.record_problems(replace(original, duration=0.8), 0, "switching")
    assert calls and all(c["contact"] == 0 and np.all(c["lo"] <= c["hi"]) for c in calls)
    from validation import presets

    controllers = presets.resolve("switching").settings.model_options()
    assert {c["model_options"] for c in calls} == {json.dumps(asdict(controllers))}


@pytest.mark.slow
def test_mode3_recording_under_a_latency_replays_each_horizon_as_the_closed_loop_solved_it(tmp_path, monkeypatch
                                                                                          ) -> None:
    """Under a 50 ms delay Mode III's first solve plans over two intervals and the next over three, so
    one recording holds problems of two lengths (saved padded, trimmed on loading). The demo's first
    1.2 s recorded (Mode III from 0.8 s), saved and loaded: both horizons are there, and each problem
    replayed as posed ends in the closed loop's own iteration count (IPOPT is deterministic on the
    same inputs), its plan as long as its horizon makes it."""
    bench = _load("mode3_solvers")
    from dataclasses import replace

    import validation.scenarios as scenarios

    calls = bench.record_problems(replace(scenarios.SCENARIOS["wall-headon"], duration=1.2), 0, "switching", "0.05")
    monkeypatch.setattr(bench, "PROBLEMS", tmp_path / "mode3_problems.npz")
    bench.save(calls, 1, ("wall-headon",), "0.05")
    data, cold, model, scene = bench.load_problems()
    assert {c["horizon"] for c in calls} == {2, 3} and cold.tolist() == [c["lam_g"] is None for c in calls]
    for i, ocp, sol in bench.replayed(data, cold, model, scene):
        assert len(data["guess"][i]) == len(calls[i]["guess"]) == len(sol.w)
        assert ocp.settings.horizon == calls[i]["horizon"] and sol.iterations == calls[i]["iterations"]


@pytest.mark.slow
def test_mode2_recorder_records_warm_startable_problems() -> None:
    """bench/mode2_warm_start.py's recorder on the demo's run (wall-headon, seed 0, Mode II after the
    switch for several steps): every problem it records comes with the previous solve's resampled
    multipliers, and one replayed warm gives a plan of the guess's horizon. Oracle: the problem's
    own layout (multipliers of the problem's constraint and variable counts)."""
    from controller.mode2 import ModeIIOCP
    from controller.model import UVMSModel
    from uvms import load_params, load_scene

    bench = _load("mode2_warm_start")
    calls = bench._record_run(("wall-headon", 0))
    assert calls
    scene = load_scene()
    ocp = ModeIIOCP(UVMSModel(load_params(), scene.water), scene.planes, calls[0]["contact"])
    ocp.limit_inputs(calls[0]["lo"], calls[0]["hi"])
    us = calls[0]["guess"][1]
    N = len(us)
    nz = ocp.ns + 1 + ocp.nu + ocp.nv
    lam_g, lam_x = calls[0]["duals"]
    assert len(lam_x) == N * nz + ocp.ns + 1 and (len(lam_g) - ocp.ns - 1) % N == 0
    sol = ocp.solve(calls[0]["h0"], calls[0]["guess"], calls[0]["current"], calls[0]["duals"])
    assert sol.u.shape == us.shape


@pytest.mark.slow
def test_mode2_solver_recorder_replays_what_the_loop_solved() -> None:
    """bench/mode2_solvers.py's recorder on the demo's run with a 50 ms delay the plant waits out
    (deterministic): every problem carries the controller's Mode II settings, whose interval bounds
    the latency scaled to (0.05, 0.1) s (SwitchingController.reset's rule), and replaying each with
    those settings on a fresh problem gives the closed loop's own iteration count and outcome
    (IPOPT is deterministic on the same inputs) on the recorded controller's model, which is what
    the benchmark's comparison needs."""
    from controller.mode2 import ModeIIOCP
    from controller.model import UVMSModel
    from uvms import load_params, load_scene

    bench = _load("mode2_solvers")
    calls = bench._record_run(("wall-headon", 0, "switching", "0.05"))
    assert calls and all(c["settings"].dt_bounds == pytest.approx((0.05, 0.1)) for c in calls)
    scene = load_scene()
    model = UVMSModel(load_params(), scene.water, calls[0]["model_options"])
    ocp = ModeIIOCP(model, scene.planes, calls[0]["contact"], calls[0]["settings"])
    for c in calls:
        ocp.limit_inputs(c["lo"], c["hi"])
        sol = ocp.solve(c["h0"], c["guess"], c["current"], c["duals"])
        assert (sol.iterations, sol.status.usable) == (c["iterations"], c["usable"])
