"""Mode II's IPOPT options on the problems closed loops posed, side by side.

Under a latency Mode II's answers are late in about 40 % of its steps (experiments/
realtime_mode3_thrust); a quarter of its solves stop at the 100-iteration cap without a usable
plan. This benchmark records every Mode II problem (entry and continuing, with the controller's own
settings, so under a latency with its stretched intervals) that MuJoCo closed loops of a preset
posed, and replays them with each option set of OPTIONS on top of Mode II's own, so that a
change of IPOPT's stopping rule is measured offline on the same problems.

  python bench/mode2_solvers.py --record 2 --latency 0.05:strict   # development seeds 0-1 of
                                       # wall-headon, wall-oblique, arm-deployed (about 2 min)
  python bench/mode2_solvers.py        # every option set on them

--record writes out/mode2_solver_problems.pkl (not committed). The evaluation writes
bench/results/mode2_solvers.md and its manifest: per option set, usable solves, iterations and
solve time (median / p95 / max, warm and cold), the cost against the first row's on the problems
both solve, and the largest constraint violation of the usable plans. Under a strict latency the
closed loops depend on the machine's speed, so recording again may pose other problems; the replay
itself is deterministic but for its times.
"""

from __future__ import annotations

import argparse
import pickle
import platform
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

from controller.mode2 import ModeIIOCP
from controller.model import ModelOptions, UVMSModel
from uvms import load_params, load_scene

OUT = Path(__file__).parent / "results"
PROBLEMS = Path(__file__).parent.parent / "out" / "mode2_solver_problems.pkl"
FAMILIES = ("wall-headon", "wall-oblique", "arm-deployed")

# name: IPOPT options on top of Mode II's own (controller.mode2), cold and warm solver alike
OPTIONS: dict[str, dict] = {
    "default (tol 1e-6, IPOPT's acceptable level: 15 iterations at 1e-6)": {},
    "acceptable level as Mode III's (dual 1e-2, constraints 1e-5), after 3": {
        "acceptable_tol": 1e-2, "acceptable_constr_viol_tol": 1e-5, "acceptable_iter": 3},
    "acceptable level as Mode III's, after 1": {
        "acceptable_tol": 1e-2, "acceptable_constr_viol_tol": 1e-5, "acceptable_iter": 1},
    "acceptable level dual 1e-3, constraints 1e-5, after 3": {
        "acceptable_tol": 1e-3, "acceptable_constr_viol_tol": 1e-5, "acceptable_iter": 3},
    "cap of 30 iterations": {"max_iter": 30},
    "barrier from mu 1e-2 (cold; warm solves too)": {"mu_init": 1e-2},
    "barrier from mu 1e-3 (cold; warm solves as their default)": {"mu_init": 1e-3},
    "monotone barrier from mu 1e-2 (cold; warm solves too)": {"mu_strategy": "monotone", "mu_init": 1e-2},
}


def _record_run(args: tuple[str, int, str, str]) -> list[dict]:
    """The Mode II problems of one closed loop (family, seed, preset, latency)."""
    from controller.switching import SolveEvent, SwitchingController
    from validation import presets
    from validation.closed_loop import run
    from validation.scenarios import SCENARIOS

    family, seed, preset, latency = args
    calls: list[dict] = []

    def recording(e: SolveEvent) -> None:
        if e.kind != "mode2":
            return
        h0, guess, current, duals = (*e.args, *(None,) * (4 - len(e.args)))[:4]
        duals = e.kwargs.get("duals", duals)
        calls.append({"h0": np.array(h0), "guess": (np.array(guess[0]), np.array(guess[1]), float(guess[2])),
                      "current": np.zeros(3) if current is None else np.array(current),
                      "duals": None if duals is None else tuple(np.array(d) for d in duals),
                      "lo": e.ocp._lo_u.copy(), "hi": e.ocp._hi_u.copy(), "contact": e.ocp.contact,
                      "settings": e.ocp.settings, "model_options": e.ocp.model.options, "family": family, "seed": seed,
                      "iterations": e.solution.iterations, "usable": e.solution.status.usable})

    run(SCENARIOS[family], seed=seed, latency=latency,
        controller=SwitchingController(presets.resolve(preset).settings, recording))
    return calls


def record(seeds: int, workers: int, preset: str, latency: str) -> None:
    jobs = [(f, s, preset, latency) for f in FAMILIES for s in range(seeds)]
    calls: list[dict] = []
    with ProcessPoolExecutor(workers) as ex:
        for c in tqdm(ex.map(_record_run, jobs), total=len(jobs), desc="closed loops", unit="run"):
            calls += c
    PROBLEMS.parent.mkdir(exist_ok=True)
    PROBLEMS.write_bytes(pickle.dumps({"seeds": seeds, "preset": preset, "latency": latency, "problems": calls}))
    print(f"{len(calls)} Mode II problems ({sum(c['duals'] is None for c in calls)} cold) -> {PROBLEMS}")


def clear_at_start(ocp: ModeIIOCP, problem: dict) -> bool:
    """Whether every body Mode II protects (ocp's plane's) is at least its margin off the planes at
    h0. A problem posed with one closer must undo the contact within its first interval: with the
    default options 10 of the 95 recorded such problems were usable, the others ran to the cap."""
    return ocp.protected_clearance(problem["h0"]) >= problem["settings"].distance_margin


def mpm(v: np.ndarray) -> str:
    """median / p95 / max of v, rounded ("-" when empty)."""
    return f"{np.median(v):.0f} / {np.percentile(v, 95):.0f} / {np.max(v):.0f}" if len(v) else "-"


def evaluate() -> None:
    if not PROBLEMS.exists():
        raise SystemExit(f"{PROBLEMS} is missing; allowed: run `python bench/mode2_solvers.py --record 2` first")
    data = pickle.loads(PROBLEMS.read_bytes())
    scene = load_scene()
    params = load_params()
    posed = data["problems"]
    models = {p.get("model_options", ModelOptions()) for p in posed}
    if len(models) != 1:
        raise SystemExit(f"{PROBLEMS} mixes the controller models {models}; allowed: one")
    model = UVMSModel(params, scene.water, models.pop())
    checks: dict[int, ModeIIOCP] = {}
    for p in posed:
        checks.setdefault(p["contact"], ModeIIOCP(model, scene.planes, p["contact"], p["settings"]))
    problems = [p for p in posed if clear_at_start(checks[p["contact"]], p)]
    n, cold = len(problems), np.array([p["duals"] is None for p in problems])
    results: dict[str, list[tuple]] = {}
    for name, opts in tqdm(OPTIONS.items(), desc="option sets", unit="set"):
        ocps: dict[tuple, ModeIIOCP] = {}
        rows = []
        for p in problems:
            settings = replace(p["settings"], ipopt_options={**p["settings"].ipopt_options, **opts})
            key = (p["contact"], settings.dt_bounds, settings.dt_nominal)
            if key not in ocps:
                ocps[key] = ModeIIOCP(model, scene.planes, p["contact"], settings)
            ocp = ocps[key]
            ocp.limit_inputs(p["lo"], p["hi"])
            sol = ocp.solve(p["h0"], p["guess"], p["current"], p["duals"])
            stats = ocp.solver(len(p["guess"][1]), p["duals"] is not None and settings.warm_start).stats()
            inf_pr = stats.get("iterations", {}).get("inf_pr", [np.nan])
            rows.append((sol.status.usable, sol.iterations, sol.solve_time, sol.cost,
                         float(inf_pr[-1]) if inf_pr else np.nan))
        results[name] = rows
    base = results[next(iter(OPTIONS))]
    families = sorted({p["family"] for p in problems})
    lines = ["# Mode II's IPOPT options on recorded problems", "",
             f"`python bench/mode2_solvers.py` ({platform.machine()}, casadi {ca.__version__}, IPOPT with MUMPS, "
             f"one process). {n} Mode II problems ({int(cold.sum())} cold entries, {n - int(cold.sum())} warm) posed "
             f"with every protected body at least its margin off the planes at h0 (of {len(posed)} posed; "
             f"{len(posed) - n} others, with a body already within its margin, almost all in the model's contact: "
             "their first interval must undo the contact, and most run to the cap) in MuJoCo closed loops of "
             f"`{data['preset']}` at latency {data['latency']} ({', '.join(families)}, "
             f"seeds 0-{data['seeds'] - 1}; `--record`), replayed with the recorded controller's Mode II settings "
             "and each option set on top. Iterations and times: median / p95 / max; cost: the median of (cost - the "
             "first row's) over the problems both solve, and on how many of them it is over 10 % higher; "
             "violation: the largest constraint violation of a usable plan.", "",
             "| options | usable | iterations, warm | iterations, cold | time, warm [ms] | time, cold [ms] | "
             "cost - first row's | costlier by 10 % | violation |", "|---|---|---|---|---|---|---|---|---|"]
    ref = np.array([b[3] for b in base])
    for name, rows in results.items():
        ok, it, t, cost, viol = (np.array(c) for c in zip(*rows, strict=True))
        both = ok & np.array([b[0] for b in base])
        dc = np.median(cost[both] - ref[both]) if both.any() else np.nan
        worse = int(np.sum(cost[both] > ref[both] + 0.1 * np.abs(ref[both])))
        lines.append(f"| {name} | {int(ok.sum())}/{n} | {mpm(it[~cold])} | {mpm(it[cold])} | "
                     f"{mpm(1e3 * t[~cold])} | {mpm(1e3 * t[cold])} | {dc:+.1e} | {worse} | "
                     f"{np.nanmax(viol[ok]) if ok.any() else np.nan:.1e} |")
    (OUT / "mode2_solvers.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--record", type=int, metavar="SEEDS", help="record the problems of seeds 0..SEEDS-1 first")
    ap.add_argument("--workers", type=int, default=2, help="closed loops in parallel while recording")
    ap.add_argument("--controller", default="switching", help="the preset whose problems --record records")
    ap.add_argument("--latency", default="none", help="the closed loops' latency while recording (uvms run --latency)")
    a = ap.parse_args(argv)
    if a.record is not None:
        if a.record < 1 or a.workers < 1:
            raise SystemExit(f"--record {a.record}, --workers {a.workers}; allowed: both >= 1")
        record(a.record, a.workers, a.controller, a.latency)
    else:
        evaluate()
    return 0


if __name__ == "__main__":
    if "--record" in sys.argv:
        sys.exit(main())
    from validation import manifest

    with manifest.recorded(OUT / "mode2_solvers.manifest.json", {"options": OPTIONS}):
        main(sys.argv[1:])
