"""Mode III: the SQP of controller.sqp against IPOPT on recorded problems, side by side.

  python bench/mode3_sqp.py --record 2   # the default controller's Mode III problems in MuJoCo closed
                                         # loops of wall-headon, wall-oblique, arm-deployed, seeds 0-1
  python bench/mode3_sqp.py              # every solver of SOLVERS on the warm-started ones

The problems are bench/mode3_solvers.py's (out/mode3_problems.npz, not committed; the closed loops
are deterministic). Only the warm-started problems count (the shifted recomputed plan and its
multipliers): the cold first solve of each Mode III entry, from Algorithm 2's guess, stays IPOPT's.
Each problem is solved by every solver one after the other. Per solver: usable solves, iterations,
time (median / p95 / max), and against IPOPT's solution on the problems both solve: the largest
difference of the first input (what the step applies), and the constraint violation and cost at the
returned plan (controller.sqp.StageSQP.evaluate, the same for every solver). Writes
bench/results/mode3_sqp.md.
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).parent))
from mode3_solvers import load_problems, record

from controller.mode1 import Solver
from controller.mode3 import ModeIIIOCP, ModeIIISettings
from controller.sqp import SQPSettings

OUT = Path(__file__).parent / "results" / "mode3_sqp.md"
IPOPT = "IPOPT, warm start (the default)"
ALONE = "SQP alone, to convergence (<= 30 iterations)"
SOLVERS: dict[str, ModeIIISettings] = {
    IPOPT: ModeIIISettings(),
    **{f"SQP, {n} iterations{floor_name}, then IPOPT if not usable": ModeIIISettings(
        solver=Solver.SQP, sqp=SQPSettings(max_iter=n, real_time=False, hessian_floor=floor))
       for n in (3, 5) for floor_name, floor in (("", 1e-6), (", Hessian floor 10", 10.0))},
    ALONE: ModeIIISettings(solver=Solver.SQP, sqp=SQPSettings(max_iter=30)),
}


def mpm(v: np.ndarray, fmt: str = "{:.0f}") -> str:
    return " / ".join(fmt.format(x) for x in (np.median(v), np.percentile(v, 95), np.max(v))) if len(v) else "-"


def evaluate() -> None:
    data, cold, model, scene = load_problems()
    warm = np.flatnonzero(~cold)
    ocps = {name: {} for name in SOLVERS}
    rows: dict[str, list] = {name: [] for name in SOLVERS}
    for i in tqdm(warm, desc="problems", unit="problem"):
        contact = int(data["contact"][i])
        for name, settings in SOLVERS.items():
            if contact not in ocps[name]:
                ocps[name][contact] = ModeIIIOCP(model, scene.planes, contact, settings)
            ocp = ocps[name][contact]
            ocp.limit_inputs(data["lo"][i], data["hi"][i])
            rows[name].append(ocp.solve(data["h0"][i], data["guess"][i], data["current"][i],
                                        (data["lam_g"][i], data["lam_x"][i])))
    judges = ocps[ALONE]  # per contact plane: one SQP's evaluate() judges every solver's plan alike
    lines = ["# Mode III: SQP against IPOPT on recorded problems", "",
             f"`python bench/mode3_sqp.py` ({platform.machine()}, casadi {ca.__version__}). {len(warm)} warm-started "
             f"Mode III problems (of {len(cold)}; the {int(cold.sum())} cold ones stay IPOPT's) that the default "
             "controller posed in MuJoCo closed loops of wall-headon, wall-oblique and arm-deployed, seeds "
             f"0-{int(data['seeds']) - 1} (`--record`), each solved by every solver one after the other. "
             "Median / p95 / max over the problems. Violation and cost: at the returned plan, evaluated the "
             "same way for every solver; |du_0|: the largest difference of the first input (N, N m) from "
             "IPOPT's, on the problems both solve.", "",
             "| solver | usable | iterations | time [ms] | violation (max) "
             "| cost - IPOPT's (median) | |du_0| [N, N m] |",
             "|---|---|---|---|---|---|---|"]
    base = rows[IPOPT]
    for name, results in rows.items():
        usable = np.array([r.status.usable for r in results])
        both = usable & np.array([b.status.usable for b in base])
        viol, dcost, du = [], [], []
        for r, b, i, ok in zip(results, base, warm, both, strict=True):
            judge = judges[int(data["contact"][i])]
            s = judge.settings
            P = np.concatenate([data["h0"][i], data["current"][i], [s.hull_clearance, s.clearance_weight],
                                judge.weights])
            v, c = judge.sqp.evaluate(r.w, P, judge.lbg[judge.ns:], judge.ubg[judge.ns:])
            _, cb = judge.sqp.evaluate(b.w, P, judge.lbg[judge.ns:], judge.ubg[judge.ns:])
            if ok:
                viol.append(v)
                dcost.append(c - cb)
                du.append(np.abs(r.u[0] - b.u[0]).max())
        its = np.array([r.iterations for r in results])
        times = np.array([r.solve_time for r in results]) * 1e3
        lines.append(f"| {name} | {usable.sum()}/{len(usable)} | {mpm(its)} | {mpm(times)} | "
                     f"{max(viol):.1e} | {np.median(dcost):+.1e} | {mpm(np.array(du), '{:.2g}')} |")
    OUT.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main(argv: list[str]) -> None:
    ap = argparse.ArgumentParser(prog="python bench/mode3_sqp.py")
    ap.add_argument("--record", type=int, metavar="SEEDS", help="record the problems of seeds 0..SEEDS-1 first")
    ap.add_argument("--workers", type=int, default=2, help="closed loops in parallel while recording")
    args = ap.parse_args(argv)
    if args.record:
        record(args.record, args.workers, "switching")
    evaluate()


if __name__ == "__main__":
    main(sys.argv[1:])
