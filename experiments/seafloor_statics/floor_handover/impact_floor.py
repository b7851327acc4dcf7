"""The straight-down strut's landing (python impact_floor.py): for a level hull 0.5 m above the
seafloor with the arm in the posture that reaches furthest down, controller.impact's predicted tip
peak and the speed Mode II's bound allows, for a hull sinking at 0.2-0.4 m/s, and the normal force
the joints can hold there (ModeIIIOCP.pushing_force, capped at the jaws' 200 N)."""

import numpy as np

from controller import impact
from controller.mode3 import ModeIIIOCP
from controller.model import UVMSModel
from controller.rollouts import ReachPosture
from uvms.params import load_params
from uvms.scene import load_scene

scene = load_scene()
model = UVMSModel(load_params(arm="alpha4"), scene.water)
floor = scene.planes[1]
h = np.zeros(model.n_states)
h[2] = -2.5
h[6:6 + model.n_joints] = ReachPosture(model, floor)(h)
gap = float(floor.normal @ np.asarray(model.ee_pose(h)[0]).ravel() + floor.offset)
print("posture [rad]", np.round(h[6:6 + model.n_joints], 2), f"tip's gap to the floor {gap:.3f} m")
for vz in (0.2, 0.3, 0.35, 0.4):
    h[model.n_speeds + 2] = -vz
    k = impact.stiffness(model, h, floor)
    print(f"sinking {vz} m/s: m_eff {impact.effective_mass(model, h, floor.normal):.1f} kg, "
          f"predicted peak {impact.peak_force(model, h, floor):.0f} N, allowed speed at 150 N {150 / k:.3f} m/s")
print(f"normal force the joints hold: {ModeIIIOCP(model, scene.planes, 1).pushing_force(h):.1f} N")
