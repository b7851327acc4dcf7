"""The observer's estimate through one closed loop (python trace.py SCENARIO SEED LATENCY
ACCELERATION, at the declaring commit): a line each time the observer updates or the mode changes, with the hull's
speed [m/s], the estimated current [m/s, world] and extra hull weight [N]. The default preset with
`observe_under_latency` and `observer.learning_acceleration` = ACCELERATION [m/s^2], default mismatch."""

import sys

import numpy as np

from controller.estimator import ObserverSettings
from controller.switching import SwitchingController, SwitchingSettings
from validation.closed_loop import run
from validation.scenarios import get

scenario, seed, latency = sys.argv[1], int(sys.argv[2]), sys.argv[3]
rows = []


class Traced(SwitchingController):
    def step(self, h, t):
        u, info = super().step(h, t)
        n = self.nmpc.model.n_speeds
        speed = float(np.linalg.norm(np.asarray(self.nmpc.model.rotation(h), float) @ np.asarray(h)[n:n + 3]))
        rows.append((t, info.mode.value, speed, *self.observer.estimate, self.observer.updates))
        return u, info


settings = SwitchingSettings(observe_under_latency=True,
                             observer=ObserverSettings(learning_acceleration=float(sys.argv[4])))
s = run(get(scenario), controller=Traced(settings), seed=seed, latency=latency)
print(s.verdict, " > ".join(s.modes), f"hull's smallest distance {s.min_hull_distance:.3f} m")
for i, r in enumerate(rows):
    if i == 0 or r[-1] != rows[i - 1][-1] or r[1] != rows[i - 1][1]:
        print(f"t={r[0]:.2f} mode={r[1]} speed={r[2]:.2f} current=({r[3]:+.3f},{r[4]:+.3f},{r[5]:+.3f}) "
              f"weight={r[6]:+.1f} N updates={r[7]}")
