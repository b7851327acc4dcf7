"""Mode III's IPOPT on the problems the default posed in MuJoCo closed loops of thrusters-dead, solved
again with J_III's or the friction law's smoothing changed: usable solves, iterations, time.

  PYTHONPATH=. python experiments/mode3_friction_smoothing/offline.py   # development seeds 0-1, about 4 min

Writes offline.md beside this file; the closed loops are deterministic, so the problems are the same
on a rerun at the same commit.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from controller.mode3 import ModeIIIOCP, ModeIIISettings
from controller.model import UVMSModel
from uvms import load_params, load_scene
from validation.scenarios import SCENARIOS

sys.path.insert(0, str(Path(__file__).parents[2] / "bench"))
from mode3_solvers import record_problems

SEEDS = range(2)
VARIANTS = {"default (friction 1 cm/s, approach 1 cm/s, clearance 1 cm)": {},
            "approach relu 3 cm/s": {"approach_smoothing": 0.03}, "clearance relu 3 cm": {"clearance_smoothing": 0.03},
            "friction 3 cm/s": {"friction_smoothing": 0.03}, "friction 5 cm/s": {"friction_smoothing": 0.05},
            "friction 10 cm/s": {"friction_smoothing": 0.1}}


def main() -> None:
    scene = load_scene()
    model = UVMSModel(load_params(), scene.water)
    problems = [p for seed in SEEDS for p in record_problems(SCENARIOS["thrusters-dead"], seed, "switching")]
    lines = ["# Mode III's IPOPT with its smoothing changed, on recorded thrusters-dead problems", "",
             f"`PYTHONPATH=. python {Path(__file__).relative_to(Path.cwd())}`: the {len(problems)} Mode III problems "
             f"of the default's thrusters-dead closed loops (default mismatch, development seeds {SEEDS.start}-"
             f"{SEEDS.stop - 1}), solved again. Iterations: median / p95 (cap 200).", "",
             "| variant | usable | iterations | time [s] |", "|---|---|---|---|"]
    for name, settings in VARIANTS.items():
        ocps: dict[int, ModeIIIOCP] = {}
        rows = []
        for p in problems:
            ocp = ocps.setdefault(p["contact"], ModeIIIOCP(model, scene.planes, p["contact"],
                                                            ModeIIISettings(**settings)))
            ocp.limit_inputs(p["lo"], p["hi"])
            duals = None if p["lam_g"] is None else (p["lam_g"], p["lam_x"])
            sol = ocp.solve(p["h0"], p["guess"], p["current"], duals)
            rows.append((sol.status.usable, sol.iterations, sol.solve_time))
        ok, it, t = (np.array(c, float) for c in zip(*rows, strict=True))
        lines.append(f"| {name} | {int(ok.sum())}/{len(ok)} | {np.median(it):.0f} / {np.percentile(it, 95):.0f} | "
                     f"{t.sum():.1f} |")
        print(lines[-1], file=sys.stderr)
    (Path(__file__).parent / "offline.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
