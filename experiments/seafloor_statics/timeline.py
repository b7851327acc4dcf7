"""One closed loop's steps, a line each (python timeline.py SCENARIO SEED MISMATCH [key=value ...]):
time [s], mode, solver status, fallback, iterations, the hull's distance to each plane [m], its
height z [m] and pitch [deg] at the measured state, the first planned contact force (obstacle frame:
normal, two tangents [N]), the contact plane and the switch reason. No latency; the default preset
with the given overrides."""

import sys
from typing import Any

import numpy as np

from controller.switching import SwitchingSettings
from validation import presets, scenarios
from validation.closed_loop import run


class Logged:
    """The preset's controller, each step's line kept in `lines`."""

    settings_type = SwitchingSettings

    def __init__(self, inner: Any) -> None:
        self.inner, self.lines = inner, []

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    def reset(self, task: Any) -> None:
        self.inner.reset(task)

    def step(self, h: np.ndarray, t: float) -> tuple[np.ndarray, Any]:
        u, info = self.inner.step(h, t)
        line = self.line(h, t, info)
        if line is not None:
            self.lines.append(line)
        return u, info

    def line(self, h: np.ndarray, t: float, info: Any) -> str | None:
        """The step's line (None: none kept)."""
        hull = np.round(np.asarray(info.distances)[:, 0], 3).tolist()
        force = None if info.contact_force is None else np.round(np.asarray(info.contact_force)[0], 1).tolist()
        return (f"{t:5.2f} {info.mode.name:>3} {info.status.value:<12} {info.fallback.name:<12} "
                f"it={info.iterations:3} hull={hull} z={h[2]:.2f} pitch={np.degrees(h[4]):5.1f} "
                f"F={force} plane={info.contact_plane} {info.switch.name if info.switch else ''}")


if __name__ == "__main__":
    name, seed, mismatch = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    overrides = dict(arg.split("=", 1) for arg in sys.argv[4:])
    ctl = Logged(presets.build(presets.resolve("switching", overrides)))
    summary = run(scenarios.get(name), ctl, mismatch=mismatch, seed=seed)
    print(summary.verdict, summary.reason)
    print("\n".join(ctl.lines))
