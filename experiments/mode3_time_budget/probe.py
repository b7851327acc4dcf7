"""Mode III's recorded problems with and without a time budget (ModeIIISettings.time_budget):
how many solves end later than 45 ms, and what the stopped iterates cost.

  python bench/mode3_solvers.py --record 2      # the problems (out/mode3_problems.npz)
  python experiments/mode3_time_budget/probe.py  # from the repository root, after it
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
from mode3_solvers import load_problems

import controller.mode3 as mode3

DUE = 0.045  # s: a step's solve later than this misses a 50 ms latency (about 5 ms for the rest of the step)


def solve_all(data: dict, cold: np.ndarray, model, scene, budget: float | None) -> list[tuple[str, float, float]]:
    ocps: dict[int, mode3.ModeIIIOCP] = {}
    out = []
    for i in range(len(cold)):
        c = int(data["contact"][i])
        if c not in ocps:
            ocps[c] = mode3.ModeIIIOCP(model, scene.planes, c, mode3.ModeIIISettings(time_budget=budget))
        ocp = ocps[c]
        ocp.limit_inputs(data["lo"][i], data["hi"][i])
        duals = None if cold[i] else (data["lam_g"][i], data["lam_x"][i])
        sol = ocp.solve(data["h0"][i], data["guess"][i], data["current"][i], duals)
        out.append((sol.status.value, sol.solve_time, sol.cost))
    return out


def main() -> None:
    data, cold, model, scene = load_problems()
    base = solve_all(data, cold, model, scene, None)
    t0 = np.array([r[1] for r in base])
    print(f"{len(base)} problems ({int(cold.sum())} cold); without a budget {int((t0 > DUE).sum())} solves over "
          f"{DUE * 1e3:.0f} ms; median / p95 / max {np.percentile(t0, [50, 95, 100]).round(3)} s\n")
    print("| budget [s] | tolerance | stopped | over 45 ms | median / p95 / max [s] "
          "| stopped cost / converged, median / p90 |")
    print("|---|---|---|---|---|---|")
    for tol in (1e-5, 1e-3, 1e-2):
        mode3.FEASIBLE_VIOLATION = tol
        runs = solve_all(data, cold, model, scene, 0.03)
        t1 = np.array([r[1] for r in runs])
        stopped = [i for i, r in enumerate(runs) if r[0] == mode3.SolverStatus.STOPPED.value]
        ratio = np.array([runs[i][2] / base[i][2] for i in stopped])
        counts = Counter(r[0] for r in runs)
        print(f"| 0.03 | {tol:g} | {counts[mode3.SolverStatus.STOPPED.value]} | {int((t1 > DUE).sum())} | "
              f"{' / '.join(f'{v:.3f}' for v in np.percentile(t1, [50, 95, 100]))} | "
              f"{' / '.join(f'{v:.4f}' for v in np.percentile(ratio, [50, 90]))} |")


if __name__ == "__main__":
    main()
