"""Offline: Mode II with and without `hold_violated = 0` on the problems strict closed loops posed.

Record first (`python bench/mode2_solvers.py --record 4 --latency 0.05:strict`, out/, not committed),
then `python probe.py` writes probe.md and its manifest: per arm and horizon class, usable plans,
IPOPT's iterations and solve times (median / p95), and how many usable plans came within 40 ms.
"""

from __future__ import annotations

import pickle
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from controller.mode2 import ModeIIOCP  # noqa: E402
from controller.model import UVMSModel  # noqa: E402
from uvms import load_params, load_scene  # noqa: E402
from validation import manifest  # noqa: E402

ARMS = {"default": {}, "hold_violated = 0": {"hold_violated": 0.0}}


def main() -> None:
    data = pickle.loads((ROOT / "out" / "mode2_solver_problems.pkl").read_bytes())
    posed, scene = data["problems"], load_scene()
    model = UVMSModel(load_params(), scene.water, posed[0]["model_options"])
    lines = ["| arm | horizon | problems | starting inside | usable | usable within 40 ms | iterations | time [ms] |",
             "|---|---|---|---|---|---|---|---|"]
    for arm, change in ARMS.items():
        ocps: dict[tuple, ModeIIOCP] = {}
        rows = []
        for p in posed:
            settings = replace(p["settings"], **change)
            key = (p["contact"], settings.dt_bounds)
            ocp = ocps.setdefault(key, ModeIIOCP(model, scene.planes, p["contact"], settings))
            ocp.limit_inputs(p["lo"], p["hi"])
            sol = ocp.solve(p["h0"], p["guess"], p["current"], p["duals"])
            inside = ocp.protected_clearance(p["h0"]) < settings.distance_margin
            rows.append((len(sol.u), inside, sol.status.usable, sol.iterations, 1e3 * sol.solve_time))
        r = np.array(rows, float)
        for name, sel in (("all", r[:, 0] > 0), ("N <= 4", r[:, 0] <= 4), ("N >= 5", r[:, 0] >= 5)):
            s = r[sel]
            timely = int(np.sum((s[:, 2] > 0) & (s[:, 4] <= 40)))
            lines.append(f"| {arm} | {name} | {len(s)} | {int(s[:, 1].sum())} | {int(s[:, 2].sum())} | {timely} | "
                         f"{np.median(s[:, 3]):.0f} / {np.percentile(s[:, 3], 95):.0f} | "
                         f"{np.median(s[:, 4]):.0f} / {np.percentile(s[:, 4], 95):.0f} |")
    head = (f"{len(posed)} Mode II problems of `{data['preset']}` at latency {data['latency']} "
            f"(seeds 0-{data['seeds'] - 1} of the three families), replayed (`python probe.py`).\n\n")
    (Path(__file__).parent / "probe.md").write_text(head + "\n".join(lines) + "\n")
    print(head + "\n".join(lines))


if __name__ == "__main__":
    with manifest.recorded(Path(__file__).parent / "probe.manifest.json", {"arms": ARMS}):
        main()
