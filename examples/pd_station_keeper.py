"""A controller of one's own, in about forty lines: a PD station keeper on the thrusters, the arm
held at its start posture by joint PDs. It speaks controller.protocol, so it runs as it is:

    uvms run avoid-wall --controller examples.pd_station_keeper:PDStationKeeper
    uvms campaign --controllers examples.pd_station_keeper:PDStationKeeper,braking --seeds 3

and `--ctl kp=60` sets its gains (they are its settings dataclass). It knows nothing of obstacles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from controller.protocol import StepInfo, Task
from uvms.conventions import euler_zyx_to_matrix


@dataclass(frozen=True)
class PDSettings:
    kp: float = 40.0  # N/m on the position error, N m/rad on the attitude error
    kd: float = 60.0  # N s/m and N m s/rad on the body velocities
    joint_kp: float = 5.0  # N m/rad
    joint_kd: float = 0.5  # N m s/rad
    dt: float = 0.1  # s, the control period


class PDStationKeeper:
    settings_type = PDSettings

    def __init__(self, settings: PDSettings = PDSettings()):
        self.settings = settings

    def reset(self, task: Task) -> None:
        self.task = task
        self.pinv = np.linalg.pinv(task.params.allocation_matrix())  # body wrench -> thrusts
        self.lo, self.hi = task.params.input_bounds()

    def step(self, h: np.ndarray, t: float) -> tuple[np.ndarray, StepInfo]:
        s, n = self.settings, self.task.params.n_joints
        ref = self.task.reference(t)
        R = euler_zyx_to_matrix(*h[3:6])
        force = R.T @ (s.kp * (ref[:3] - h[:3])) - s.kd * h[6 + n:9 + n]  # body frame, N
        angle = (ref[3:6] - h[3:6] + np.pi) % (2 * np.pi) - np.pi  # small-angle attitude error, rad
        torque = s.kp * angle - s.kd * h[9 + n:12 + n]  # N m
        joints = s.joint_kp * (self.task.h0[6:6 + n] - h[6:6 + n]) - s.joint_kd * h[12 + n:12 + 2 * n]
        u = np.clip(np.concatenate([self.pinv @ np.concatenate([force, torque]), joints]), self.lo, self.hi)
        for i in self.task.failed_thrusters(t):
            u[i] = 0.0
        return u, StepInfo(t=t, dt=s.dt, mode="pd")
