"""Mode II's IPOPT warm-started from the previous plan's multipliers, on recorded problems.

Mode II's solves follow one another within a phase: each starts from the previous plan shifted and
resampled onto the new horizon (controller.mode2.shifted_guess). This benchmark replays the Mode II
problems that MuJoCo closed loops posed with such a plan before them, solved cold (IPOPT from the
primal guess alone, its adaptive barrier from mu 0.1) and warm (the previous solution's multipliers
resampled the same way, controller.mode2.ModeIIOCP.shifted_duals, with a monotone barrier from a
small mu), so that the choice is made on the same problems side by side.

  python bench/mode2_warm_start.py --record 2   # the problems of the default with cold Mode II solves on
                                                # wall-headon, wall-oblique, arm-deployed and thrusters-dead,
                                                # seeds 0-1 (development seeds; about 3 min)
  python bench/mode2_warm_start.py              # every variant of VARIANTS on them

--record writes out/mode2_problems.pkl (not committed; the closed loops are deterministic). The
evaluation writes bench/results/mode2_warm_start.md and its manifest: per variant, usable solves,
iterations and solve time (median / p95 / max) and the cost against the cold solve's on the
problems both solve. Times are wall clock on a shared machine; the iterations are what changes.
"""

from __future__ import annotations

import argparse
import pickle
import platform
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

from controller.mode2 import ModeIIOCP, ModeIISettings
from controller.model import UVMSModel
from uvms import load_params, load_scene

OUT = Path(__file__).parent / "results"
PROBLEMS = Path(__file__).parent.parent / "out" / "mode2_problems.pkl"
FAMILIES = ("wall-headon", "wall-oblique", "arm-deployed", "thrusters-dead")

# name: the warm solver's barrier (None: the cold solve, no multipliers)
VARIANTS: dict[str, dict | None] = {
    "cold (adaptive barrier from mu 0.1; the previous default)": None,
    "warm, monotone barrier from mu 1e-4": {"mu_strategy": "monotone", "mu_init": 1e-4},
    "warm, monotone barrier from mu 1e-3": {"mu_strategy": "monotone", "mu_init": 1e-3},
    "warm, monotone barrier from mu 1e-2": {"mu_strategy": "monotone", "mu_init": 1e-2},
    "warm, adaptive barrier from mu 1e-3": {"mu_init": 1e-3},
}


def _record_run(args: tuple[str, int]) -> list[dict]:
    """The warm-startable Mode II problems of one closed loop (family, seed) of the default with
    cold Mode II solves."""
    from dataclasses import replace

    from controller.switching import SolveEvent, SwitchingController, SwitchingSettings
    from validation.closed_loop import run
    from validation.scenarios import SCENARIOS

    family, seed = args
    calls: list[dict] = []

    def recording(e: SolveEvent) -> None:
        if e.kind != "mode2" or len(e.args) < 4 or e.args[3] is None:
            return
        h0, guess, current, duals = e.args[:4]
        calls.append({"h0": np.array(h0), "guess": (np.array(guess[0]), np.array(guess[1]), float(guess[2])),
                      "current": np.zeros(3) if current is None else np.array(current),
                      "duals": tuple(np.array(d) for d in duals), "lo": e.ocp._lo_u.copy(), "hi": e.ocp._hi_u.copy(),
                      "contact": e.ocp.contact, "model_options": e.ocp.model.options, "family": family,
                      "seed": seed})

    settings = SwitchingSettings()
    settings = replace(settings, mode2=replace(settings.mode2, warm_start=False))
    run(SCENARIOS[family], seed=seed, controller=SwitchingController(settings, recording))
    return calls


def record(seeds: int, workers: int) -> None:
    jobs = [(f, s) for f in FAMILIES for s in range(seeds)]
    calls: list[dict] = []
    with ProcessPoolExecutor(workers) as ex:
        for c in tqdm(ex.map(_record_run, jobs), total=len(jobs), desc="closed loops", unit="run"):
            calls += c
    PROBLEMS.parent.mkdir(exist_ok=True)
    PROBLEMS.write_bytes(pickle.dumps({"seeds": seeds, "problems": calls}))
    print(f"{len(calls)} warm-startable Mode II problems -> {PROBLEMS}")


def mpm(v: np.ndarray) -> str:
    """median / p95 / max of v, rounded ("-" when empty)."""
    return f"{np.median(v):.0f} / {np.percentile(v, 95):.0f} / {np.max(v):.0f}" if len(v) else "-"


def evaluate() -> None:
    if not PROBLEMS.exists():
        raise SystemExit(f"{PROBLEMS} is missing; allowed: run `python bench/mode2_warm_start.py --record 2` first")
    data = pickle.loads(PROBLEMS.read_bytes())
    problems = data["problems"]
    scene = load_scene()
    models = {p.get("model_options") for p in problems}
    if len(models) != 1 or None in models:
        raise SystemExit(f"{PROBLEMS} does not hold one controller model's options; allowed: record again")
    model = UVMSModel(load_params(), scene.water, models.pop())
    n = len(problems)
    results: dict[str, list[tuple]] = {}
    for name, opts in tqdm(VARIANTS.items(), desc="variants", unit="variant"):
        ocps: dict[int, ModeIIOCP] = {}
        rows = []
        for p in problems:
            if p["contact"] not in ocps:
                ocps[p["contact"]] = ModeIIOCP(model, scene.planes, p["contact"], ModeIISettings())
                if opts is not None:
                    ocps[p["contact"]]._warm_ipopt.update(opts)
            ocp = ocps[p["contact"]]
            ocp.limit_inputs(p["lo"], p["hi"])
            sol = ocp.solve(p["h0"], p["guess"], p["current"], None if opts is None else p["duals"])
            rows.append((sol.status.usable, sol.iterations, sol.solve_time, sol.cost))
        results[name] = rows
    base = results[next(iter(VARIANTS))]
    families = sorted({p["family"] for p in problems})
    lines = ["# Mode II's IPOPT, cold or warm-started, on recorded problems", "",
             f"`python bench/mode2_warm_start.py` ({platform.machine()}, casadi {ca.__version__}, IPOPT with MUMPS, "
             f"one process). {n} Mode II problems with a previous plan before them, posed in MuJoCo closed loops of "
             f"the default with cold Mode II solves ({', '.join(families)}, seeds 0-{data['seeds'] - 1}; `--record`). "
             "Iterations and times: median / p95 / max over the problems (cap: 100 iterations); cost: the median "
             "of (cost - the cold solve's cost) over the problems both solve.", "",
             "| variant | usable | iterations | time [ms] | cost - cold's |", "|---|---|---|---|---|"]
    for name, rows in results.items():
        ok, it, t, cost = (np.array(c) for c in zip(*rows, strict=True))
        both = ok & np.array([b[0] for b in base])
        dc = np.median(cost[both] - np.array([b[3] for b in base])[both]) if both.any() else np.nan
        lines.append(f"| {name} | {int(ok.sum())}/{n} | {mpm(it)} | {mpm(1e3 * t)} | {dc:+.1e} |")
    (OUT / "mode2_warm_start.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--record", type=int, metavar="SEEDS", help="record the problems of SEEDS seeds per family")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    if args.record:
        record(args.record, args.workers)
    else:
        evaluate()
    return 0


if __name__ == "__main__":
    if "--record" in sys.argv:
        sys.exit(main())
    from validation import manifest

    with manifest.recorded(OUT / "mode2_warm_start.manifest.json", {"variants": VARIANTS}):
        main(sys.argv[1:])
