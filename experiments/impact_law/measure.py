"""The tip's impact on the wall: controller.impact's law against MuJoCo's measured peak force.

Run: `python experiments/impact_law/measure.py`. The hull and the arm coast (no thrust, no torque)
into the wall from 2 mm off, in five postures at three speeds; writes results.md and manifest.json beside this file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from controller import impact
from controller.model import UVMSModel
from uvms import load_params, load_scene
from uvms_mj.build import TIP_GEOM
from uvms_mj.plant import Plant
from validation import manifest

HERE = Path(__file__).parent
POSTURES = {"straight (strut)": (0.0, 0.0, 0.0, 0.0), "shoulder 0.3 (strut)": (0.0, 0.3, 0.0, 0.0),
            "home (folded)": (0.0, 0.3, 0.6, 0.0), "folded down": (0.0, 0.6, 0.3, 0.0),
            "yawed, folded": (0.5, 0.3, 0.3, 0.0)}
SPEEDS = (0.2, 0.5, 0.8)


def coast(plant: Plant, h: np.ndarray) -> tuple[float, np.ndarray]:
    """MuJoCo's peak tip normal force [N] and the state one physics step before the tip touched."""
    plant.reset(h)
    u, before, first, peak = np.zeros(plant.params.n_inputs), plant.state(), None, 0.0
    for _ in range(500):
        rep = plant.step(u, plant.model.opt.timestep)
        tip = [c.peak_normal_force for c in rep.contacts if c.geom == TIP_GEOM]
        if tip:
            first, peak = before if first is None else first, max(peak, *tip)
        elif first is not None:
            break
        before = rep.h
    return peak, first


def main() -> None:
    with manifest.recorded(HERE / "manifest.json", {"postures": POSTURES, "speeds": SPEEDS}):
        params, scene = load_params(), load_scene()
        model, plant = UVMSModel(params, scene.water), Plant(params, scene)
        wall, n = next(p for p in scene.planes if p.name == "wall"), params.n_joints
        lines = ["| posture | speed [m/s] | m_eff [kg] | law [N] | MuJoCo [N] | MuJoCo / law |",
                 "|---|---|---|---|---|---|"]
        for name, q in POSTURES.items():
            for v in SPEEDS:
                h = np.zeros(model.n_states)
                h[2], h[6:6 + n], h[6 + n] = -1.5, q, v
                gap = float(wall.signed_distance(np.asarray(model.ee_pose(h)[0]).ravel())) - params.arm.tip_radius
                h[:3] -= (gap - 0.002) * wall.normal
                measured, first = coast(plant, h)
                law = impact.peak_force(model, first, wall)
                lines.append(f"| {name} | {v} | {impact.effective_mass(model, first, wall.normal):.2f} | {law:.1f} | "
                             f"{measured:.1f} | {measured / law:.3f} |")
        (HERE / "results.md").write_text("\n".join(lines) + "\n")
        print("\n".join(lines))


if __name__ == "__main__":
    main()
