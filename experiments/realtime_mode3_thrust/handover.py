"""Mode II's hand-over to Mode III in one closed loop: python handover.py FAMILY SEED LATENCY.

Prints, for each Mode II step, the tip's gap to the contact plane at the measured state and at the
end of the plan re-simulated by the model's RK4, and, at each hand-over check, the gap at the
state the check reads (the predicted one under a latency) and whether the tip counts as short; and
the joints: measured, planned from (the predicted state under a latency) and to, their rates and
the step's torques."""

import sys

import numpy as np

from controller import switching
from controller.transcription import tip_gap
from validation import presets
from validation.closed_loop import run
from validation.scenarios import SCENARIOS

short_of_contact, step = switching.SwitchingNMPC._short_of_contact, switching.SwitchingNMPC.step


def checked(self, h):
    short = short_of_contact(self, h)
    gap = float(tip_gap(self.model, h, self.planes[self.contact]))
    print(f"   hand-over check: tip gap {gap:.3f} m, short: {short}")
    return short


def traced(self, h, t, ahead=None):
    u, info = step(self, h, t, ahead)
    if info.mode.value == "II" and info.h_pred is not None:
        plane, n = self.planes[self.contact], self.model.n_joints
        now, end = float(tip_gap(self.model, h, plane)), float(tip_gap(self.model, info.h_pred[-1], plane))
        print(f"{t:.3f} Mode II N={info.horizon} dt={info.dt:.3f} tip gap now {now:.3f} m, at the plan's end "
              f"{end:.3f} m ({info.status.value})")
        start = h if ahead is None else ahead[0]
        print(f"   joints [rad]: now {np.round(h[6:6 + n], 2)}, planned from {np.round(start[6:6 + n], 2)} to "
              f"{np.round(info.h_pred[-1][6:6 + n], 2)}; rates now {np.round(h[-n:], 1)} rad/s; "
              f"torques {np.round(u[-n:], 1)} N m")
    return u, info


switching.SwitchingNMPC._short_of_contact, switching.SwitchingNMPC.step = checked, traced
family, seed, latency = sys.argv[1], int(sys.argv[2]), sys.argv[3]
summary = run(SCENARIOS[family], seed=seed, latency=latency,
              controller=switching.SwitchingController(presets.resolve("switching").settings))
print(summary.verdict, summary.reason)
