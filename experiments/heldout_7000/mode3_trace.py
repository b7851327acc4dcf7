"""Per step of one run: mode, fallback, the hull's distance to the wall, its pitch and the joints;
in Mode III also the plan's normal force per interval, the hull's distance at the plan's end and
the joint torques.

    MUJOCO_GL=egl python experiments/heldout_7000/mode3_trace.py thrusters-dead 7013 default
"""

import sys

import numpy as np

from validation import closed_loop, presets
from validation import mismatch as mm
from validation.scenarios import get

scenario, seed, mismatch = sys.argv[1], int(sys.argv[2]), sys.argv[3]
ctl = presets.build(presets.resolve("switching", {}))
step = ctl.step


def traced(h: np.ndarray, t: float):
    u, info = step(h, t)
    model, wall = ctl.nmpc.model, ctl.nmpc.planes[0]

    def hull(x: np.ndarray) -> float:
        return 100 * float(np.asarray(model.distances(x, wall.normal, wall.offset)).ravel()[0])

    line = (f"t={t:.2f} {info.mode.value:3s} {info.fallback.value[:12]:12s} d={hull(h):5.1f}cm "
            f"pitch={np.degrees(h[4]):6.1f} q={np.round(h[6:10], 2)}")
    if info.contact_force is not None and len(info.h_pred) > 1:
        line += (f" Fn={np.round(info.contact_force[:, 0], 0)} d_end={hull(info.h_pred[-1]):5.1f}cm "
                 f"tau={np.round(u[8:], 1)}")
    print(line, flush=True)
    return u, info


ctl.step = traced
closed_loop.run(get(scenario), ctl, mismatch=mm.resolve(mismatch), seed=seed)
