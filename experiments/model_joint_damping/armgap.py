"""The arm's free swing, the controller's model against the MuJoCo plant: python armgap.py.

From rest at the home posture, the shoulder and elbow driven at 30 % of their torque limits for
0.15 s, hull free, open water; the joint angles [rad] at the end, for physics switched on in steps."""

import numpy as np

from controller.model import ModelOptions, UVMSModel
from uvms import load_params, load_scene
from uvms_mj.build import BuildOptions
from uvms_mj.plant import Plant, PlantSettings

params, scene = load_params(), load_scene()
water, n = scene.with_planes(()), params.n_joints
_, hi = params.input_bounds()
CASES = {
    "added mass only, no damping": (ModelOptions(drag=False), BuildOptions(fluid=False, joint_damping=False)),
    "drag only, no damping": (ModelOptions(added_mass=False), BuildOptions(added_mass=False, joint_damping=False)),
    "full, no joint damping": (ModelOptions(), BuildOptions(joint_damping=False)),
    "full, joint damping in the plant only": (ModelOptions(), BuildOptions()),
    "full, joint damping in both": (ModelOptions(joint_damping=True), BuildOptions()),
}
for label, (model_options, plant_options) in CASES.items():
    model = UVMSModel(params, water.water, model_options)
    plant = Plant(params, water, PlantSettings(build=BuildOptions(**{**plant_options.__dict__, "joint_limits": False,
                                                                     "timestep": 0.0005})))
    h = np.zeros(params.n_states)
    h[6:6 + n] = params.arm.home
    plant.reset(h)
    u = np.zeros(params.n_inputs)
    u[-n:] = 0.3 * hi[-n:] * np.array([0.0, -1.0, -1.0, 0.0])
    hm = h.copy()
    for _ in range(15):
        hp = plant.step(u, 0.01).h
        for _ in range(4):
            hm = model.step(hm, u, 0.0025, vc=np.zeros(3))
    print(f"{label:40s} model {np.round(hm[6:6 + n], 3)}  plant {np.round(hp[6:6 + n], 3)}")
