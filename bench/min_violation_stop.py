"""The certificate's minimum-violation IPOPT on the problems MuJoCo closed loops actually posed:
its verdicts, iterations and solve times, replayed offline one after the other.

  python bench/min_violation_stop.py --record 2   # record RUNS' problems (2 workers, a few minutes)
  python bench/min_violation_stop.py              # replay them with the default certificate

--record writes out/min_violation_problems.npz (not committed; the closed loops are deterministic
on one machine), from the controller's `on_solve` hook: per problem the run, the measured state,
the task reference, the current the controller assumes, the input bounds (dead thrusters) and the
primal start the certificate gave IPOPT (Mode I's fresh plan, else the braking rollout). The replay
writes bench/results/min_violation_stop.md: verdicts, how many 'feasible' ones rest on a plan whose
inputs re-simulated by the model's RK4 keep the margin, iterations and solve times. Times are wall
clock on a shared machine.
"""

from __future__ import annotations

import argparse
import platform
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

from controller.feasibility import FeasibilityTest, Verdict
from controller.model import UVMSModel
from controller.rollouts import simulate
from validation import mismatch, scenarios
from validation.closed_loop import build_plant

OUT = Path(__file__).parent / "results" / "min_violation_stop.md"
PROBLEMS = Path(__file__).parent.parent / "out" / "min_violation_problems.npz"
# the runs whose problems are recorded: the three hardest families and thrusters-dead, a few seeds each
RUNS = ("wall-oblique:0", "wall-oblique:1", "wall-oblique:2", "wall-oblique:3", "wall-headon:0", "wall-headon:1",
        "wall-headon:2", "arm-deployed:0", "arm-deployed:1", "thrusters-dead:0", "thrusters-dead:1",
        "mission-near-wall:0")
KEYS = ("h0", "h_ref", "current", "lo", "hi", "guess")


def _record_run(run_name: str, duration: float | None = None) -> list[dict]:
    """The minimum-violation problems of one closed loop (default preset and mismatch; `duration`
    [s]: the scenario's own when None)."""
    from controller.switching import SolveEvent, SwitchingController
    from validation.closed_loop import run

    name, seed = run_name.split(":")
    calls: list[dict] = []

    def recording(e: SolveEvent) -> None:
        if e.kind != "certificate":
            return
        h0, h_ref, current = e.args[:3]
        ns, nu = e.ocp.ns, e.ocp.nu
        calls.append({"run": run_name, "h0": np.array(h0), "h_ref": np.array(h_ref),
                      "current": np.zeros(3) if current is None else np.array(current),
                      "lo": e.ocp.lbw[ns:ns + nu].copy(), "hi": e.ocp.ubw[ns:ns + nu].copy(),
                      "guess": np.array(e.kwargs["guess"])})

    sc = scenarios.get(name)
    sc = sc if duration is None else replace(sc, duration=duration)
    run(sc, controller=SwitchingController(on_solve=recording), mismatch=mismatch.DEFAULT, seed=int(seed))
    return calls


def record(workers: int) -> None:
    calls: list[dict] = []
    with ProcessPoolExecutor(workers) as ex:
        for c in tqdm(ex.map(_record_run, RUNS), total=len(RUNS), desc="closed loops", unit="run"):
            calls += c
    PROBLEMS.parent.mkdir(exist_ok=True)
    np.savez_compressed(PROBLEMS, run=np.array([c["run"] for c in calls]),
                        **{k: np.array([c[k] for c in calls]) for k in KEYS})
    print(f"{len(calls)} problems from {len(RUNS)} runs -> {PROBLEMS}")


def mpm(v: list[float], fmt: str = "{:.0f}") -> str:
    """median / p95 / max."""
    return " / ".join(fmt.format(x) for x in (np.median(v), np.percentile(v, 95), np.max(v)))


def evaluate() -> None:
    if not PROBLEMS.exists():
        raise SystemExit(f"{PROBLEMS} is missing; allowed: run `python bench/min_violation_stop.py --record 2` first")
    data = dict(np.load(PROBLEMS))
    tests: dict[str, FeasibilityTest] = {}
    rows = []
    n = len(data["run"])
    for i in tqdm(range(n), desc="problems", unit="problem"):
        run_name = str(data["run"][i])
        if run_name not in tests:
            name, seed = run_name.split(":")
            params, scene, _, _ = build_plant(scenarios.get(name), mismatch.DEFAULT, int(seed))
            tests[run_name] = FeasibilityTest(UVMSModel(params, scene.water), scene.planes)
        test = tests[run_name]
        test.limit_inputs(data["lo"][i], data["hi"][i])
        h0, current = data["h0"][i], data["current"][i]
        sol = test.problem.solve(h0, data["h_ref"][i], current, guess=data["guess"][i])
        verdict = test.judge(sol, np.nan, sol.solve_time, np.zeros(0), np.zeros(0)).verdict
        physical = verdict is Verdict.FEASIBLE and test.plan_is_feasible(
            simulate(test.model, h0, sol.u, test.settings.dt, current=current), sol.u)
        rows.append((verdict, sol.iterations, sol.solve_time, physical))
    feas = [x for x in rows if x[0] is Verdict.FEASIBLE]
    lines = ["# The certificate's minimum-violation IPOPT on recorded problems", "",
             f"`python bench/min_violation_stop.py` ({platform.machine()}, casadi {ca.__version__}; {n} problems "
             f"recorded by `--record 2` in {len(RUNS)} MuJoCo closed loops of the default preset: "
             f"{', '.join(RUNS)}). Iterations and solve time: median / p95 / max.", "",
             "| 'feasible' | of them re-simulated within the margin | 'unavoidable' | iterations | solve time [s] |",
             "|---|---|---|---|---|",
             f"| {len(feas)} | {sum(x[3] for x in feas)} | {n - len(feas)} | {mpm([x[1] for x in rows])} | "
             f"{mpm([x[2] for x in rows], '{:.2f}')} |", ""]
    OUT.write_text("\n".join(lines))
    print("\n".join(lines))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--record", type=int, metavar="WORKERS", help="record the problems with this many workers")
    a = ap.parse_args()
    record(a.record) if a.record else evaluate()


if __name__ == "__main__":
    from validation import manifest

    with manifest.recorded(Path(__file__).parent / "results" / "min_violation_stop.manifest.json"):
        main()
