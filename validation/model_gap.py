"""The gap between the paper's model (controller/, CasADi) and the MuJoCo plant (uvms_mj/) under
the same open-loop inputs from the same initial state: the mismatch this testbed exists to expose.

`python -m validation.model_gap` prints the position and attitude divergence after 1, 5 and 10 s,
with the plant's full physics and with fluid, added mass and joint friction off on both sides.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from controller.model import ModelOptions, UVMSModel
from uvms import load_params, load_scene
from uvms.conventions import euler_zyx_to_matrix
from uvms.params import UVMSParams
from uvms.scene import Scene
from uvms_mj.build import BuildOptions
from uvms_mj.plant import Plant, PlantSettings

FULL_MODEL = ModelOptions()
RIGID_MODEL = ModelOptions(added_mass=False, drag=False)
# The model has no joint limits or joint friction (the OCP bounds the joints): off in the plant too.
FULL_PLANT = BuildOptions(joint_limits=False)
RIGID_PLANT = BuildOptions(fluid=False, added_mass=False, joint_damping=False, joint_limits=False, timestep=0.00025)


@dataclass(frozen=True)
class Gap:
    """Divergence of the model from the plant at time t [s]: hull position [m], attitude [deg]
    (angle of R_model^T R_plant), joint angles [deg, max over joints]."""

    t: float
    position: float
    attitude: float
    joints: float


def open_loop_inputs(params: UVMSParams, t: float) -> np.ndarray:
    """A smooth test input: 10 N forward, 2 N up, a slow yaw torque; the arm's joints are free."""
    wrench = np.array([10.0, 0.0, 2.0, 0.0, 0.0, 0.5 * np.sin(0.5 * t)])
    thrust = np.linalg.pinv(params.allocation_matrix()) @ wrench
    return np.concatenate([thrust, np.zeros(params.n_joints)])


def open_loop_gap(params: UVMSParams, scene: Scene, times: tuple[float, ...] = (1.0, 5.0, 10.0),
                  model_options: ModelOptions = FULL_MODEL, plant_options: BuildOptions = FULL_PLANT,
                  period: float = 0.01) -> list[Gap]:
    """Drive both with `open_loop_inputs` held over `period` [s]; the model integrates each period
    with RK4 in 4 substeps. Open water (no obstacles)."""
    water = scene.with_planes(())
    model = UVMSModel(params, water.water, model_options)
    plant = Plant(params, water, PlantSettings(build=plant_options))
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[6:6 + n] = params.arm.home
    plant.reset(h)
    gaps, t = [], 0.0
    vc = scene.current.at(0.0)
    for target in times:
        while t < target - 1e-9:
            u = open_loop_inputs(params, t)
            hp = plant.step(u, period).h
            for _ in range(4):
                h = model.step(h, u, period / 4, vc=vc)
            t += period
        dR = euler_zyx_to_matrix(*h[3:6]).T @ euler_zyx_to_matrix(*hp[3:6])
        angle = np.degrees(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1)))
        gaps.append(Gap(t=round(t, 6), position=float(np.linalg.norm(h[:3] - hp[:3])), attitude=float(angle),
                        joints=float(np.degrees(np.max(np.abs(h[6:6 + n] - hp[6:6 + n]))))))
    return gaps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.parse_args()
    params, scene = load_params(), load_scene()
    print("| physics | t [s] | position gap [m] | attitude gap [deg] | joint gap [deg] |")
    print("|---|---|---|---|---|")
    for label, mo, po in (("full (plant: MuJoCo fluid; model: Fossen + cross-flow)", FULL_MODEL, FULL_PLANT),
                          ("rigid + hydrostatics only, both sides", RIGID_MODEL, RIGID_PLANT)):
        for g in open_loop_gap(params, scene, model_options=mo, plant_options=po):
            print(f"| {label} | {g.t:g} | {g.position:.4f} | {g.attitude:.3f} | {g.joints:.3f} |")


if __name__ == "__main__":
    main()
