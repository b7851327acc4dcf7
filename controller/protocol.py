"""The controller protocol that the testbed's closed loop drives.

A controller is any object with

    reset(task: Task) -> None                     once, before the run: what it is told
    step(h: np.ndarray, t: float) -> (u, StepInfo) every control period

and, optionally,

    sense(wrench: np.ndarray) -> None             before each step but the first
    late(u: np.ndarray) -> None                   after a step whose answer was discarded

`h` is the measured state in the paper's layout (controller.model.UVMSModel: position, ZYX Euler
angles, joint angles | body-frame velocities, joint rates), `t` the simulated time [s]; `u` the
thruster forces [N] and joint torques [N m] to hold for `StepInfo.dt` seconds. `wrench` is what a
tared force/torque sensor between the last joint and the arm's last link read, averaged over the
period since the previous step: the contact force on that link and its tip [N] and its torque about
the end-effector point [N m], world frame (as the model's contact wrench Fw with Rw = I).
`late` tells a controller that strict real time discarded its step's answer (it overran the
latency) and applied `u`, the input it had committed in advance, in its place, from the latency
after that step's state until the next input acts: what its own clock would tell it on a vehicle.
A class may declare `settings_type`, a frozen dataclass: the testbed then builds it as `Class(settings)` with the
preset's and the command line's dotted overrides applied (validation.presets), else as `Class()`.
The switching NMPC (controller.switching.SwitchingController), its Mode-I-only baseline and the
braking baseline (controller.baselines) are implementations; examples/ has a small one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any, Protocol, runtime_checkable

import numpy as np

from uvms.params import UVMSParams
from uvms.scene import Scene


@dataclass(frozen=True)
class KnownFault:
    """Thrusters the controller is told are dead from time `at` [s] on."""

    thrusters: tuple[int, ...]
    at: float = 0.0


@dataclass(frozen=True)
class Task:
    """What a controller is told before a run: its (nominal) vehicle, the scene (water, obstacle
    planes, the current it knows: scene.current.at(t) [m/s, world]), the start state, the reference
    h_ref(t), the faults it is told of, the run's length [s], the latency [s]: each input but the
    first step's acts from `latency` after its state's sample (0: the plant waits for the
    controller), whether the world runs on the wall clock (strict real time or a measured delay:
    what a controller computes between its steps, in another process, competes with the world, not
    with the loop), and the vehicle's weight in water as a trim check before the run measured it
    (None: not measured)."""

    name: str
    params: UVMSParams
    scene: Scene
    h0: np.ndarray
    reference: Callable[[float], np.ndarray]
    known_faults: tuple[KnownFault, ...] = ()
    duration: float = 0.0
    latency: float = 0.0  # s: each input reaches the thrusters this long after its state's sample
    wall_clock: bool = False  # the loop runs at the wall clock's pace (strict real time, a measured delay)
    trim: float | None = None  # N, positive: sinks; whole vehicle, still water, at h0 (uvms_mj Plant.trim_weight)

    def failed_thrusters(self, t: float) -> tuple[int, ...]:
        """The thrusters known to be dead at time t [s] (sorted)."""
        return tuple(sorted({i for f in self.known_faults if t >= f.at - 1e-9 for i in f.thrusters}))


def label(value: Enum | str | None) -> str | None:
    """An Enum's value or the string itself (StepInfo's mode, status and fallback)."""
    return value.value if isinstance(value, Enum) else value


@dataclass(frozen=True)
class StepInfo:
    """What one control step decided. Only t and dt are required; the rest is what the controller
    can say (the switching NMPC fills it all; None: not applicable)."""

    t: float  # s
    dt: float  # s: how long the input is meant to be held
    mode: Enum | str = "-"  # the switching NMPC: controller.switching.Mode
    status: Enum | str = "-"  # the solver's verdict ("-": no solver) (controller.transcription.SolverStatus)
    fallback: Enum | str = "none"  # "none", or the fallback used (controller.switching.Fallback)
    solve_time: float = 0.0  # s, the whole step as the controller timed it
    ocp_time: float = 0.0  # s, the optimal-control solve alone
    iterations: int = 0
    horizon: int = 0  # N_p
    h_pred: np.ndarray | None = None  # (N+1, ns) predicted states
    u_pred: np.ndarray | None = None  # (N, nu) planned inputs, each for dt: the first is the input returned, the
    # next are what it commits to should its following steps come too late (validation.closed_loop, strict)
    commit_after: np.ndarray | None = None  # (K, nu) inputs committed past the plan's end, after u_pred's rows
    contact_force: np.ndarray | None = None  # (N, 3) planned contact force, obstacle frame [N]
    contact_plane: int | None = None  # index of the plane the contact is planned on
    distances: np.ndarray | None = None  # (n_planes, n_bodies) m, at the measured state
    closing_speeds: np.ndarray | None = None  # (n_planes, n_bodies) m/s
    certificate: Any = None  # the switching NMPC: controller.feasibility.Certificate
    switch: Enum | str | None = None  # why this step left Mode I (controller.switching.SwitchReason)
    impact_force: float | None = None  # N: the planned contact's predicted peak tip force (controller.impact)
    water: np.ndarray | None = None  # what the model assumed (controller.model.water): current m/s, world (3);
    # the hull's extra weight in water, N (the known current plus the observer's estimate, if it has one)


@runtime_checkable
class Controller(Protocol):
    """The protocol (module docstring; `settings_type` is optional)."""

    def reset(self, task: Task) -> None: ...

    def step(self, h: np.ndarray, t: float) -> tuple[np.ndarray, StepInfo]: ...
