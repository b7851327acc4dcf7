"""The observer's estimate step by step in one closed-loop run, against the drawn truth.

PYTHONPATH=. MUJOCO_GL=egl python experiments/weight_observer/trace.py thrusters-dead 7110 [wide]
"""

from __future__ import annotations

import sys

import numpy as np

from controller.switching import SwitchingController, SwitchingSettings
from uvms import load_params, load_scene
from validation import mismatch
from validation.closed_loop import run
from validation.scenarios import get


class Traced(SwitchingController):
    """The switching NMPC with the observer, printing each step's mode and estimate."""

    def step(self, h: np.ndarray, t: float):
        u, info = super().step(h, t)
        print(f"t {t:5.2f} s  mode {info.mode.name:3}  free {self._last[3]!s:5}  current "
              f"{info.water[0]:+.3f} {info.water[1]:+.3f} m/s  extra weight {info.water[3]:+7.2f} N")
        return u, info


def main(scenario: str, seed: int, spec: str = "wide") -> None:
    terms = mismatch.resolve(spec)
    drawn = mismatch.draw(terms, seed)
    params, scene = load_params(), load_scene()
    weight = (drawn.get("mass", 1.0) - 1.0) * params.hull.mass * scene.water.gravity
    known = get(scenario).current.velocities[0]
    print(f"drawn: {drawn}\ntruth: extra weight {weight:+.2f} N (mass alone), current "
          f"{known[0] + drawn.get('current', 0.0):+.3f} m/s along x (known {known[0]:+.3f})")
    s = run(get(scenario), controller=Traced(SwitchingSettings(observe_current=True)), mismatch=terms, seed=seed)
    print(s.verdict, s.hull_contact_impulse)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), *sys.argv[3:4])
