"""The braking baseline behind the controller protocol: maximum thruster braking with attitude
hold, the arm held at its start posture (controller.rollouts.BrakingPolicy), every period of the
Mode I interval."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from controller.model import UVMSModel
from controller.protocol import StepInfo, Task
from controller.rollouts import BrakingPolicy


@dataclass(frozen=True)
class BrakingSettings:
    dt: float = 0.1  # s, the control period


class BrakingController:
    """Maximum braking (module docstring); known dead thrusters get zero bounds."""

    settings_type = BrakingSettings

    def __init__(self, settings: BrakingSettings = BrakingSettings()):
        if settings.dt <= 0:
            raise ValueError(f"dt {settings.dt} s; allowed: dt > 0")
        self.settings = settings
        self._task: Task | None = None

    def reset(self, task: Task) -> None:
        self._task = task
        self._policy = BrakingPolicy(UVMSModel(task.params, task.scene.water))
        self._posture = np.asarray(task.h0, float)[6:6 + task.params.n_joints].copy()
        self._failed: tuple[int, ...] = ()

    def step(self, h: np.ndarray, t: float) -> tuple[np.ndarray, StepInfo]:
        if self._task is None:
            raise ValueError("step before reset; allowed: reset(task) first")
        failed = self._task.failed_thrusters(t)
        if failed != self._failed:
            lo, hi = self._task.params.input_bounds()
            lo[list(failed)] = hi[list(failed)] = 0.0
            self._policy.limit_thrust(lo, hi)
            self._failed = failed
        u = self._policy(np.asarray(h, float), self._posture, self._task.scene.current.at(t))
        return u, StepInfo(t=t, dt=self.settings.dt, mode="braking")
