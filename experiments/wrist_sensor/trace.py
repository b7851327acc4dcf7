"""One wide thrusters-dead run of the default, traced every other step: mode, fallback, the hull's
roll / pitch / yaw [deg], the tip's position [m, world], the hull's distance to the wall [m] (the
model's), the joint angles [rad].

PYTHONPATH=. MUJOCO_GL=egl python experiments/wrist_sensor/trace.py SEED
"""

from __future__ import annotations

import sys

import numpy as np

from controller.protocol import label
from controller.switching import SwitchingController
from validation import mismatch, presets
from validation.closed_loop import run
from validation.scenarios import SCENARIOS


class Traced(SwitchingController):
    """The default, recording what each step saw."""

    rows: list[tuple]

    def step(self, h, t):
        u, info = super().step(h, t)
        model, plane = self.nmpc.model, self.nmpc.planes[0]
        tip = np.asarray(model.ee_pose(h)[0]).ravel()
        gap = float(np.asarray(model.distances(h, plane.normal, plane.offset))[0, 0])
        self.rows.append((t, label(info.mode), label(info.fallback), np.degrees(h[3:6]), tip, gap,
                          h[6:6 + model.n_joints].copy()))
        return u, info


def main() -> None:
    seed = int(sys.argv[1])
    controller = Traced(presets.resolve("switching").settings)
    controller.rows = []
    s = run(SCENARIOS["thrusters-dead"], seed=seed, mismatch=mismatch.WIDE, controller=controller)
    print(s.verdict, {k: round(v, 3) for k, v in s.mismatch["values"].items()})
    for t, mode, fallback, rpy, tip, gap, q in controller.rows[::2]:
        print(f"{t:4.2f} {mode:4s} {fallback[:14]:14s} rpy {rpy[0]:6.1f} {rpy[1]:6.1f} {rpy[2]:6.1f} "
              f"tip {tip[0]:6.3f} {tip[1]:6.3f} {tip[2]:6.3f} hull {gap:6.3f} q {np.round(q, 2)}")


if __name__ == "__main__":
    main()
