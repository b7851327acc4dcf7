"""Mode I solve times in closed loop on the model (issue 4's benchmark, first part).

The avoidable approach of tests/test_mode1.py (0.3 m/s towards the wall, target out of reach),
80 control periods of 0.1 s, each warm-started from the previous solution; the model itself as the
plant (RK4, 10 ms). Variants side by side in one run: per-stage derivatives compiled to C
(controller.stage_nlp, the default) and the same NLP expanded into one SX graph with CasADi's own
derivatives. Build time includes compiling unless cached. Run: `python bench/nmpc_mode1.py`;
writes bench/results/nmpc_mode1.json and .md.
"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import casadi as ca
import numpy as np

from controller.mode1 import ModeIOCP, ModeISettings
from controller.model import UVMSModel
from uvms import load_params, load_scene

OUT = Path(__file__).parent / "results"
STEPS = 80


def run(compiled: bool) -> dict:
    params, scene = load_params(), load_scene()
    model = UVMSModel(params, scene.water)
    settings = ModeISettings(compiled=compiled)
    t0 = time.perf_counter()
    ocp = ModeIOCP(model, scene.planes, settings)
    build = time.perf_counter() - t0
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[6:6 + n], h[6 + n] = params.arm.home, 0.3
    ref = np.zeros(params.n_states)
    ref[0], ref[6:6 + n] = 1.8, params.arm.home
    previous, times, iters, statuses = None, [], [], []
    for _ in range(STEPS):
        sol = ocp.solve(h, ref, previous=previous)
        previous = sol
        times.append(sol.solve_time)
        iters.append(sol.iterations)
        statuses.append(sol.status.value)
        for _ in range(10):
            h = model.step(h, sol.u[0], settings.dt / 10)
    t = np.array(times) * 1e3
    return {"build_s": build, "median_ms": float(np.median(t)), "p95_ms": float(np.percentile(t, 95)),
            "max_ms": float(t.max()), "median_iterations": float(np.median(iters)), "max_iterations": int(max(iters)),
            "failures": sum(s != "success" for s in statuses)}


def main() -> None:
    rows = {"compiled stage derivatives": run(True), "expanded SX NLP": run(False)}
    OUT.mkdir(exist_ok=True)
    (OUT / "nmpc_mode1.json").write_text(json.dumps({"machine": platform.machine(), "casadi": ca.__version__,
                                                     "steps": STEPS, "rows": rows}, indent=2))
    lines = [f"# Mode I closed loop on the model ({platform.machine()}, casadi {ca.__version__})", "",
             f"{STEPS} warm-started solves, N = 20, dt = 0.1 s, IPOPT (MUMPS). Targets of issue 4: median <= 10 ms, "
             "p95 <= 25 ms.", "",
             "| variant | build [s] | median [ms] | p95 [ms] | max [ms] | iterations (median / max) | failures |",
             "|---|---|---|---|---|---|---|"]
    for k, r in rows.items():
        lines.append(f"| {k} | {r['build_s']:.1f} | {r['median_ms']:.0f} | {r['p95_ms']:.0f} | {r['max_ms']:.0f} | "
                     f"{r['median_iterations']:.0f} / {r['max_iterations']} | {r['failures']} |")
    (OUT / "nmpc_mode1.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
