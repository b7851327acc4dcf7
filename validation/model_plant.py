"""The paper's model itself as a plant, with a penalty contact at the end-effector tip: the closed
loop of the switching NMPC without MuJoCo (validation.kane_closed_loop).

Contact: the tip's sphere against every plane, normal force F_n = max(0, k pen - c v_n) (a stiff
spring-damper, k = 2e4 N/m, c = 300 N s/m) and the same regularized Coulomb law as the controller's
Mode III (F_t = -mu F_n v_t / sqrt(|v_t|^2 + delta^2)), held over substeps of 2 ms of the model's
RK4. Only the tip makes contact; every body's signed distance to every plane is recorded, so a
hull or link that reaches a plane shows as a negative distance (the run's failure), not as a bounce.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from controller.model import UVMSModel, water
from uvms.scene import Plane


@dataclass(frozen=True)
class TipContact:
    stiffness: float = 2e4  # N/m
    damping: float = 300.0  # N s/m
    friction: float = 0.5  # mu
    slip_speed: float = 0.01  # m/s, delta


@dataclass(frozen=True)
class ModelPlantReport:
    h: np.ndarray  # state at the end of the period
    min_distance: np.ndarray  # (n_planes, n_bodies) m, smallest over the period's substeps
    tip_force_peak: float  # N, largest tip normal force in the period
    tip_force_mean: np.ndarray  # (3,) N, world, mean over the period
    tip_velocity: np.ndarray  # (3,) m/s, world, at the end


class ModelPlant:
    def __init__(self, model: UVMSModel, planes: Sequence[Plane], h0: np.ndarray, contact: TipContact = TipContact(),
                 substep: float = 0.002, current: np.ndarray | None = None, failed_thrusters: Sequence[int] = ()):
        self.model, self.planes, self.contact, self.substep = model, tuple(planes), contact, substep
        self.h = np.asarray(h0, float).copy()
        self.current = water(current)  # model.water: current [m/s, world], extra hull weight [N]
        self.failed = list(failed_thrusters)
        self.t = 0.0

    def tip_force(self, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Contact force on the tip (world, N) and the tip's velocity (world, m/s)."""
        m, c = self.model, self.contact
        x = np.asarray(m.ee_pose(h)[0]).ravel()
        v = np.asarray(m.jacobian_ee(h))[:3] @ h[m.n_speeds:]
        F = np.zeros(3)
        for pl in self.planes:
            pen = m.params.arm.tip_radius - (pl.normal @ x + pl.offset)
            if pen <= 0:
                continue
            vn = pl.normal @ v
            fn = max(0.0, c.stiffness * pen - c.damping * vn)
            vt = v - vn * pl.normal
            F += fn * pl.normal - c.friction * fn * vt / np.sqrt(vt @ vt + c.slip_speed ** 2)
        return F, v

    def step(self, u: np.ndarray, duration: float) -> ModelPlantReport:
        m = self.model
        u = np.asarray(u, float).copy()
        u[self.failed] = 0.0
        steps = max(1, round(duration / self.substep))
        dmin = np.full((len(self.planes), len(m.body_names)), np.inf)
        peak, Fsum = 0.0, np.zeros(3)
        for _ in range(steps):
            F, _ = self.tip_force(self.h)
            peak = max(peak, float(np.max([pl.normal @ F for pl in self.planes] + [0.0])))
            Fsum += F
            self.h = m.step(self.h, u, duration / steps, Fw=np.concatenate([F, np.zeros(3)]), Rw=np.eye(3),
                            vc=self.current)
            for i, pl in enumerate(self.planes):
                dmin[i] = np.minimum(dmin[i], np.asarray(m.distances(self.h, pl.normal, pl.offset)).ravel())
        self.t += duration
        _, v = self.tip_force(self.h)
        return ModelPlantReport(self.h.copy(), dmin, peak, Fsum / steps, v)
