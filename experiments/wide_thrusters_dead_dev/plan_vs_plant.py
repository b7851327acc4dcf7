"""Mode III's plan against the plant: for each Mode III step between 1 and 3 s, the hull's distance
to the wall then, the distance the plan predicted one interval later, and what MuJoCo gave; and the
joint angles planned and reached.

    MUJOCO_GL=egl python experiments/wide_thrusters_dead_dev/plan_vs_plant.py thrusters-dead 104 wide
"""
import sys

import numpy as np

from validation import closed_loop, presets
from validation import mismatch as mm
from validation.scenarios import get

scen, seed, mis = sys.argv[1], int(sys.argv[2]), sys.argv[3]
ctl = presets.build(presets.resolve("switching", {}))
step = ctl.step
prev = {}
def hooked(h, t):
    u, info = step(h, t)
    n = ctl.nmpc
    wall = n.planes[0]
    d_now = float(np.asarray(n.model.distances(h, wall.normal, wall.offset)).ravel()[0])
    if "pred" in prev:
        tp, dp, q_pred, q_prev = prev.pop("pred")
        print(f"t={tp:.2f} hull d: was {dp*100:.1f} cm, plan said {q_pred*100:.1f} cm, plant gave {d_now*100:.1f} cm | "
              f"q plan {np.round(q_prev,2)} plant {np.round(h[6:10],2)}")
    if info.mode.value == "III" and info.fallback.value == "none" and 1.0 < t < 3.0:
        d_pred = float(np.asarray(n.model.distances(info.h_pred[1], wall.normal, wall.offset)).ravel()[0])
        prev["pred"] = (t, d_now, d_pred, info.h_pred[1][6:10])
    return u, info
ctl.step = hooked
closed_loop.run(get(scen), ctl, mismatch=mm.resolve(mis), seed=seed)
