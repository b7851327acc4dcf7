"""The certificate's minimum-violation IPOPT: its start (Mode I's fresh plan or the braking rollout),
its early stop (controller.feasibility.Stop) and Mode I's pitch bound, on the problems MuJoCo closed
loops actually posed.

  python bench/min_violation_stop.py --record 2   # record RUNS' problems (2 workers, about 4 min)
  python bench/min_violation_stop.py              # solve each under every CONFIGS entry (about 25 min)

--record writes out/min_violation_problems.npz (not committed; the closed loops are deterministic):
per problem the run, the measured state, the task reference, the current the controller assumes,
the input bounds (dead thrusters) and the primal starts (the braking rollout's, and Mode I's fresh
plan's, NaN where the step had none: then the braking rollout's stands in). The evaluation
solves every problem under each entry of CONFIGS, one after the other, and writes
bench/results/min_violation_stop.md: verdicts, where they differ from the default's, iterations
and solve times, and how many 'feasible' verdicts rest on a plan whose inputs, re-simulated by the
model's RK4, do not keep the margin (the midpoint rule's F but not the model's). Times are wall
clock on a shared machine; iterations are deterministic.
"""

from __future__ import annotations

import argparse
import platform
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

from controller.feasibility import FeasibilityTest, Stop, Verdict
from controller.mode1 import ModeISettings
from controller.model import UVMSModel
from controller.rollouts import simulate
from validation import mismatch, scenarios
from validation.closed_loop import build_plant

OUT = Path(__file__).parent / "results" / "min_violation_stop.md"
PROBLEMS = Path(__file__).parent.parent / "out" / "min_violation_problems.npz"
# the runs whose minimum-violation problems are recorded: wall-oblique seeds 11, 15 and 19 had the
# longest certificate steps of the 72-run campaigns (bench/results/certificate_cap300)
RUNS = ("wall-oblique:11", "wall-oblique:15", "wall-oblique:19", "wall-oblique:0", "wall-oblique:1",
        "wall-oblique:2", "wall-oblique:3", "wall-oblique:5", "wall-headon:0", "wall-headon:1", "wall-headon:2",
        "wall-headon:3", "wall-headon:4", "arm-deployed:0", "thrusters-dead:0", "thrusters-dead:1",
        "mission-near-wall:0")
# the closed loops' controller: the default of the fifth session of 2026-12-01, whose problems the
# first table was measured on (the default since poses others: its runs take other paths)
RECORDED_CONTROLLER = "switching-slack-stop"
# name: (where IPOPT stops early, Mode I's pitch bound [rad] or None, start from Mode I's fresh plan);
# the default first
CONFIGS: dict[str, tuple[Stop, float | None, bool]] = {
    "witness stop from Mode I's plan (the default)": (Stop.WITNESS, ModeISettings().pitch_limit, True),
    "witness stop from the braking rollout": (Stop.WITNESS, ModeISettings().pitch_limit, False),
    "slack stop and pitch bound (the default of the fifth session of 2026-12-01)":
        (Stop.SLACK, ModeISettings().pitch_limit, False),
    "pitch bound alone": (Stop.NONE, ModeISettings().pitch_limit, False),
    "slack stop alone": (Stop.SLACK, None, False),
    "neither (before the fifth session of 2026-12-01)": (Stop.NONE, None, False),
}
KEYS = ("h0", "h_ref", "current", "lo", "hi", "guess", "plan_guess")


def _record_run(run_name: str) -> list[dict]:
    """The minimum-violation problems of one closed loop (default controller and mismatch)."""
    import controller.feasibility as fz
    import controller.mode1 as m1
    from validation.closed_loop import run

    name, seed = run_name.split(":")
    calls: list[dict] = []
    solve, certify = m1.ModeIOCP.solve, fz.FeasibilityTest.__call__
    candidate: dict = {}

    def certifying(self, h0, h_ref, current=None, previous=None, plan=None, fresh=None, minimum_violation=True):
        def kept():
            candidate["plan"] = fresh()
            return candidate["plan"]

        candidate["plan"] = None
        return certify(self, h0, h_ref, current, previous, plan, kept if fresh is not None else None,
                       minimum_violation)

    def recording(self, h0, h_ref, current=None, previous=None, guess=None, sqp=None):
        if self.min_violation:
            nu, ns = self.nu, self.ns
            plan = candidate.get("plan")
            calls.append({"run": run_name, "h0": np.array(h0), "h_ref": np.array(h_ref),
                          "current": np.zeros(3) if current is None else np.array(current),
                          "lo": self.lbw[ns:ns + nu].copy(), "hi": self.ubw[ns:ns + nu].copy(),
                          "guess": np.array(guess), "plan_guess": np.full(len(guess), np.nan) if plan is None
                          else self.guess_from_rollout(*plan)})
        return solve(self, h0, h_ref, current, previous, guess, sqp)

    m1.ModeIOCP.solve = recording
    fz.FeasibilityTest.__call__ = certifying
    run(scenarios.get(name), controller=RECORDED_CONTROLLER, mismatch=mismatch.DEFAULT, seed=int(seed))
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
    tests: dict[tuple[str, str], FeasibilityTest] = {}
    rows: dict[str, list[tuple]] = {name: [] for name in CONFIGS}
    n = len(data["run"])
    for i in tqdm(range(n), desc="problems", unit="problem"):
        run_name = str(data["run"][i])
        for config, (stop, pitch, plan_start) in CONFIGS.items():
            if (run_name, config) not in tests:
                name, seed = run_name.split(":")
                params, scene, _, _ = build_plant(scenarios.get(name), mismatch.DEFAULT, int(seed))
                tests[run_name, config] = FeasibilityTest(UVMSModel(params, scene.water), scene.planes,
                                                          ModeISettings(pitch_limit=pitch), stop=stop)
            test = tests[run_name, config]
            test.limit_inputs(data["lo"][i], data["hi"][i])
            h0, current = data["h0"][i], data["current"][i]
            plan = data["plan_guess"][i]
            guess = plan if plan_start and not np.isnan(plan[0]) else data["guess"][i]
            sol = test.problem.solve(h0, data["h_ref"][i], current, guess=guess)
            verdict = test.judge(sol, np.nan, sol.solve_time, np.zeros(0), np.zeros(0)).verdict
            physical = verdict is Verdict.FEASIBLE and test.plan_is_feasible(
                simulate(test.model, h0, sol.u, test.settings.dt, current=current), sol.u)
            rows[config].append((verdict, sol.iterations, sol.solve_time, physical))
    lines = ["# The certificate's minimum-violation IPOPT: its start, its early stop, Mode I's pitch bound", "",
             f"`python bench/min_violation_stop.py` ({platform.machine()}, casadi {ca.__version__}; {n} problems "
             f"recorded by `--record 2` in {len(RUNS)} MuJoCo closed loops of `{RECORDED_CONTROLLER}`: "
             f"{', '.join(RUNS)}). Each problem solved under each configuration, one after the other. "
             "Iterations and solve time: median / p95 / max. 'Re-simulated within the margin': the plan's inputs "
             "under the model's RK4 (4 substeps) keep every clearance and bound (the plans of a run-to-its-end "
             "IPOPT need not: the midpoint rule's F, not the model's).", "",
             "| configuration | 'feasible' | of them re-simulated within the margin | 'unavoidable' | iterations | "
             "solve time [s] |", "|---|---|---|---|---|---|"]
    for config, r in rows.items():
        feas = [x for x in r if x[0] is Verdict.FEASIBLE]
        lines.append(f"| {config} | {len(feas)} | {sum(x[3] for x in feas)} | {n - len(feas)} | "
                     f"{mpm([x[1] for x in r])} | {mpm([x[2] for x in r], '{:.2f}')} |")
    default = rows[next(iter(CONFIGS))]
    lines.append("")
    for config, r in list(rows.items())[1:]:
        differ = [i for i in range(n) if r[i][0] is not default[i][0]]
        lines.append(f"- {config}: {len(differ)} verdicts differ from the default's" + (": " + "; ".join(
            f"{data['run'][i]} #{i} {r[i][0].value} ({r[i][1]} iterations, {r[i][2]:.1f} s) against "
            f"{default[i][0].value} ({default[i][1]})" for i in differ) if differ else "."))
    lines.append("")
    OUT.write_text("\n".join(lines))
    print("\n".join(lines))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--record", type=int, metavar="WORKERS", help="record the problems with this many workers")
    a = ap.parse_args()
    record(a.record) if a.record else evaluate()


if __name__ == "__main__":
    main()
