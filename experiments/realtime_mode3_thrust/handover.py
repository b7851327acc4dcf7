"""Mode II's hand-over to Mode III in one closed loop: python handover.py FAMILY SEED LATENCY.

Prints, for each Mode II step, the tip's gap to the contact plane at the measured state and at the
end of the plan re-simulated by the model's RK4, and, at each hand-over check, the gap at the
state the check reads (the predicted one under a latency) and whether the tip counts as short."""

import sys

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
        plane = self.planes[self.contact]
        now, end = float(tip_gap(self.model, h, plane)), float(tip_gap(self.model, info.h_pred[-1], plane))
        print(f"{t:.3f} Mode II N={info.horizon} dt={info.dt:.3f} tip gap now {now:.3f} m, at the plan's end "
              f"{end:.3f} m ({info.status.value})")
    return u, info


switching.SwitchingNMPC._short_of_contact, switching.SwitchingNMPC.step = checked, traced
family, seed, latency = sys.argv[1], int(sys.argv[2]), sys.argv[3]
summary = run(SCENARIOS[family], seed=seed, latency=latency,
              controller=switching.SwitchingController(presets.resolve("switching").settings))
print(summary.verdict, summary.reason)
