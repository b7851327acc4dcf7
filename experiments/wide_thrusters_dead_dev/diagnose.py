"""What the plant and Mode II see after Mode III gives up (thrusters-dead, wide mismatch, seed 104).

Run at commit 5d1d053 (its `mode3.attitude_weight` exists there only):
    MUJOCO_GL=egl python experiments/wide_thrusters_dead_dev/diagnose.py
Prints, for the first Mode II steps after t = 1.7 s: the solve's status, the tip's gap to the wall,
each body's distance to the wall (hull, base, shoulder, elbow, tip link) [cm], the clearance of the
bodies Mode II protects, the attitude [deg] and the joint angles [rad].
"""

import numpy as np

from controller.transcription import tip_gap
from validation import closed_loop, presets
from validation import mismatch as mm
from validation.scenarios import get

ctl = presets.build(presets.resolve("switching", {"mode3.attitude_weight": 3.0}))
step, printed = ctl.step, []


def reporting_step(h: np.ndarray, t: float):
    u, info = step(h, t)
    nmpc = ctl.nmpc
    if info.mode.value == "II" and t > 1.7 and len(printed) < 8:
        wall = nmpc.planes[0]
        d = np.asarray(nmpc.model.distances(h, wall.normal, wall.offset)).ravel()
        printed.append(t)
        print(f"t={t:.3f} {info.status.value} N={info.horizon} dt={info.dt:.3f} "
              f"tip gap={100 * float(tip_gap(nmpc.model, h, wall)):.2f} cm distances={np.round(100 * d, 1)} cm "
              f"protected={100 * nmpc.ocp2(0).protected_clearance(h):.1f} cm "
              f"rpy={np.round(np.degrees(h[3:6]))} deg q={np.round(h[6:10], 2)} rad")
    return u, info


ctl.step = reporting_step
closed_loop.run(get("thrusters-dead"), ctl, mismatch=mm.resolve("wide"), seed=104)
