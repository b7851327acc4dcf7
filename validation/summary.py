"""A closed-loop run's summary: the typed schema written to summary.json and read by the command
line, campaigns and tests (`Summary.read(path)`)."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class StepRecord:
    """One control step (times in s)."""

    t: float  # the state's sample time
    dt: float  # the step's period (its input's hold, or the delay when that is longer)
    delay: float  # from the sample to the input reaching the plant (the latency contract)
    mode: str  # the controller's label (the switching NMPC: I, II, III)
    status: str  # its solver's status
    fallback: str  # "none" or the fallback used
    compute_time: float  # the controller's step() as the loop timed it (wall clock)
    solve_time: float  # the controller's own timing of its step
    ocp_time: float  # the optimal-control solve alone
    iterations: int
    horizon: int
    certificate: dict | None  # Mode I's feasibility verdict (verdict, method, violation m, seconds)
    switch: str | None  # why the step left Mode I
    impact_force: float | None = None  # N: the planned contact's predicted peak tip force
    overrun: bool = False  # the computation took longer than the declared latency


@dataclass(frozen=True)
class ModeTiming:
    """A mode's step computation times [s] (the loop's wall-clock timing of step()) and its overruns
    (steps that took longer than the declared latency)."""

    steps: int
    median_s: float
    p95_s: float
    max_s: float
    p99_s: float = float("nan")
    overruns: int = 0


@dataclass(frozen=True)
class Summary:
    """A run's result. Distances in m, impulses in N s, forces in N, times in s."""

    scenario: dict  # the resolved scenario
    controller: str  # preset name or package.module:Class
    controller_settings: dict | None  # the resolved settings (None: the class takes none)
    controller_overrides: dict  # the dotted overrides that made them (preset's, then --ctl)
    mismatch: dict  # spec, seed, the drawn values and the trim told to the controller [N] (told_trim)
    latency: str
    verdict: str  # validation.closed_loop.Outcome's value
    reason: str
    modes: list[str]  # the mode sequence, repeats removed
    timeline: list[list]  # [t, mode] at each change
    min_distance: dict[str, dict[str, float]]  # geom -> plane -> smallest signed distance
    min_hull_distance: float | None
    hull_contact_impulse: float
    hull_peak_contact_force: float
    ee_peak_contact_force: float  # the end-effector tip's peak normal force
    link_contact_impulse: float  # arm links other than the tip
    max_total_thrust_along_wall_normal: float  # the thrusters' best total push away from the wall (the plane
    # named "wall", else the scene's first)
    final_task_error: float  # position error at the end
    final_joint_angles: list[float]
    solve_time: dict[str, ModeTiming]  # per mode
    fallbacks: int  # steps that used a fallback
    switches: str  # "n (k by solver failure)": Mode I -> II switches
    overruns: int  # steps whose computation took longer than the declared latency (0 without one)
    simulated_s: float
    wall_clock_s: float
    steps: list[StepRecord]

    TIMINGS = ("wall_clock_s", "solve_time", "steps")  # machine-dependent fields

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def write(self, path: Path) -> None:
        path.write_text(json.dumps(self.to_dict(), indent=1))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Summary:
        known = {f.name for f in fields(cls)}
        if set(data) - known or known - set(data):
            raise ValueError(f"summary fields {sorted(set(data) ^ known)} differ from the schema; allowed: "
                             f"{', '.join(sorted(known))}")
        data = {**data, "solve_time": {m: ModeTiming(**v) for m, v in data["solve_time"].items()},
                "steps": [StepRecord(**s) for s in data["steps"]]}
        return cls(**data)

    @classmethod
    def read(cls, path: Path) -> Summary:
        return cls.from_dict(json.loads(Path(path).read_text()))

    def without_timings(self) -> dict[str, Any]:
        """The summary as data with every machine-dependent figure removed (for same-machine golden
        comparisons): wall-clock times, and the steps' timings."""
        d = self.to_dict()
        for k in ("wall_clock_s", "solve_time"):
            d.pop(k)
        for s in d["steps"]:
            for k in ("compute_time", "solve_time", "ocp_time"):
                s.pop(k)
            if s["certificate"] is not None:
                s["certificate"].pop("seconds", None)
        return d
