"""A floor hand-over probe's steps on the seafloor (python steps.py SEED LEAD; wide mismatch,
thrusters-dead, no latency): time, mode, status, iterations, horizon N and its span T [s], the
hull's distance to the floor [m], its vertical speed [m/s], the tip's gap to the floor [m] and its
vertical speed, Mode II's predicted impact peak [N], Mode III's first planned force (normal,
tangent) [N] and the joint angles [rad]. Needs the probe's code (commit 22e07d2, with its
environment switches FLOOR_NO_IMPACT or FLOOR_STRUT; see the README)."""

import sys
from pathlib import Path
from typing import Any

import numpy as np

from controller import switching as sw
from validation import presets, scenarios
from validation.closed_loop import run

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from timeline import Logged


class FloorLogged(Logged):
    """timeline.py's logged controller, a line per step on the floor (plane 1) only."""

    def line(self, h: np.ndarray, t: float, info: Any) -> str | None:
        if info.contact_plane != 1:
            return None
        nmpc = self.inner.nmpc
        gap = float(sw.tip_gap(nmpc.model, h, nmpc.planes[1]))
        v_tip = float(np.asarray(nmpc.model.jacobian_ee(h))[2, :] @ h[10:])
        peak = None if info.impact_force is None else round(float(info.impact_force), 1)
        force = None if info.contact_force is None else np.round(np.asarray(info.contact_force)[0, :2], 1).tolist()
        return (f"{t:5.2f} {info.mode.name:>3} {info.status.value[:10]:<10} it={info.iterations:3} N={info.horizon:2} "
                f"T={info.horizon * info.dt:.2f} hull_up={np.asarray(info.distances)[1, 0]:.3f} vz={h[12]:+.2f} "
                f"tipgap={gap:.3f} tip_vz={v_tip:+.2f} impact={peak} F={force} q={np.round(h[6:10], 2).tolist()}")


if __name__ == "__main__":
    seed, lead = int(sys.argv[1]), float(sys.argv[2])
    ctl = FloorLogged(presets.build(presets.resolve("switching", {"floor_handover": lead})))
    summary = run(scenarios.get("thrusters-dead"), ctl, mismatch="wide", seed=seed)
    print(summary.verdict, summary.reason)
    print("\n".join(ctl.lines))
