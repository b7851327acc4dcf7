"""Mode II's IPOPT on the problems the default posed in MuJoCo closed loops, solved again with J_II's
terms changed: iterations, steps at the cap, time, and the planned contact (the tip's speed at the
last node, controller.impact's predicted peak).

  PYTHONPATH=. python experiments/mode2_speed_smoothing/offline.py   # development seeds 0-3, about 4 min

Writes offline.md beside this file; the closed loops are deterministic, so the problems are the same
on a rerun at the same commit.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np

from controller.mode2 import ModeIIOCP, ModeIISettings
from controller.model import UVMSModel
from controller.switching import SolveEvent, SwitchingController
from uvms import load_params, load_scene
from validation import presets
from validation.closed_loop import run
from validation.scenarios import SCENARIOS

FAMILIES = ("thrusters-dead", "wall-headon", "wall-oblique")
SEEDS = range(4)
PREVIOUS = {"ee_speed_smoothing": 0.02}  # the default these problems were recorded with
VARIANTS = {"default (smoothing 0.02 m/s)": PREVIOUS, "smoothing 0.05 m/s": {"ee_speed_smoothing": 0.05},
            "smoothing 0.1 m/s": {"ee_speed_smoothing": 0.1}, "no tip-speed term": {**PREVIOUS, "ee_speed_weight": 0.0},
            "no impact penalty": {**PREVIOUS, "impact_fraction": None}}


def record(family: str) -> list[dict]:
    """Every Mode II problem of the closed loops of `family` on SEEDS, Mode II as PREVIOUS."""
    calls: list[dict] = []

    def recording(e: SolveEvent) -> None:
        if e.kind == "mode2":
            h0, guess, current, duals = (*e.args, *(None,) * (4 - len(e.args)))[:4]
            calls.append({"h0": np.array(h0), "guess": guess, "current": current, "duals": duals,
                          "lo": e.ocp._lo_u.copy(), "hi": e.ocp._hi_u.copy(), "contact": e.ocp.contact})

    settings = presets.resolve("switching").settings
    settings = replace(settings, mode2=replace(settings.mode2, **PREVIOUS))
    for seed in SEEDS:
        run(SCENARIOS[family], seed=seed, controller=SwitchingController(settings, recording))
    return calls


def main() -> None:
    scene = load_scene()
    model = UVMSModel(load_params(), scene.water)
    h = ca.SX.sym("h", model.n_states)
    tip_speed = ca.Function("v", [h], [ca.norm_2(model.jacobian_ee(h)[:3, :] @ h[model.n_speeds:])])
    lines = ["# Mode II's IPOPT with J_II's terms changed, on recorded problems", "",
             f"`PYTHONPATH=. python {Path(__file__).relative_to(Path.cwd())}`: every Mode II problem of the default's "
             f"closed loops with Mode II's term at 0.02 m/s (the default they were recorded with; default mismatch, "
             f"development seeds {SEEDS.start}-{SEEDS.stop - 1}), solved again. "
             "Iterations: median / p95 (cap 100); tip speed [m/s] and predicted peak [N] at the plan's last node: "
             "median over the problems every variant solves.", "",
             "| family | variant | usable | iterations, cold | iterations, warm | at the cap | time [s] | tip speed "
             "| predicted peak [N] |", "|---|---|---|---|---|---|---|---|---|"]
    for family in FAMILIES:
        problems = record(family)
        rows = {}
        for name, settings in VARIANTS.items():
            ocps: dict[int, ModeIIOCP] = {}
            rows[name] = []
            for p in problems:
                ocp = ocps.setdefault(p["contact"], ModeIIOCP(model, scene.planes, p["contact"],
                                                              ModeIISettings(**settings)))
                ocp.limit_inputs(p["lo"], p["hi"])
                sol = ocp.solve(p["h0"], p["guess"], p["current"], p["duals"])
                rows[name].append((sol.status.usable, sol.iterations, sol.solve_time, p["duals"] is None,
                                   float(tip_speed(sol.h[-1])), sol.impact_force))
        both = np.all([[r[0] for r in v] for v in rows.values()], axis=0)
        for name, v in rows.items():
            ok, it, t, cold, speed, peak = (np.array(c, float) for c in zip(*v, strict=True))
            c = cold == 1

            def mp(x: np.ndarray) -> str:
                return f"{np.median(x):.0f} / {np.percentile(x, 95):.0f}" if len(x) else "-"

            lines.append(f"| {family} | {name} | {int(ok.sum())}/{len(ok)} | {mp(it[c])} | {mp(it[~c])} | "
                         f"{int((it >= 100).sum())} | {t.sum():.1f} | {np.median(speed[both]):.3f} | "
                         f"{np.median(peak[both]):.0f} |")
        print("\n".join(lines[-len(VARIANTS):]), file=sys.stderr)
    (Path(__file__).parent / "offline.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
