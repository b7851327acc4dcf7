"""An observer of the water current the controller does not know, from measured states alone.

What it estimates: the extra current c [m/s, world frame, x y z] that, added to the current the
controller knows, makes the controller's own model (controller.model.UVMSModel) reproduce the
measured motion of the hull over each control period.

Method: one Gauss-Newton step per control period on the hull's body velocity, then a first-order
filter. From the measured state h_prev and the input u_prev held over dt, the model predicts
h_pred(c) = `held_steps(h_prev, u_prev, dt, substeps, vc=known + c)`. The residual r is the measured
minus the predicted hull linear body velocity [m/s] (and, with `angular_weight` > 0, the angular one
[rad/s] times that weight [m/rad]); its Jacobian J = dr/dc (3x3 or 6x3) is taken by central finite
differences of the prediction about the present estimate (6 calls of the compiled `held_steps`, so
no code beyond the model's own is compiled). The damped least-squares step
    delta = (J^T J + lambda I)^-1 J^T r
is bounded for any J, singular or tiny ones included (|delta| <= |r| / (2 sqrt(lambda))), and the
estimate moves towards c + delta by a first-order lag of time constant tau:
    c <- c + (1 - exp(-dt / tau)) * (clip(c + delta) - c),
where clip scales a vector longer than `max_speed` back onto that sphere. The estimate is thus
always within `max_speed` (a convex combination of points inside the ball) and never NaN: a
non-finite state or prediction leaves it unchanged. One step per period suffices because the
prediction starts from the measured state each time (no model state drifts) and the filter averages
many such steps; on the model itself only the filter's lag remains (tests/test_estimator.py).
Why the velocity residual: a current acts on the hull through the relative velocity in drag and
added-mass forces, i.e. on accelerations; the change of velocity over a period is the measurable
effect, and positions carry no more information one period ahead. The angular residual is off by
default: a uniform current exerts little moment, and what moment the plant has (MuJoCo's Kutta
lift and Munk moment, the links' ellipsoid fit) is where the two fluid models differ most (with a
weight of 1 m/rad the MuJoCo estimate moved by 3 mm/s, no closer to the injected current).

What it cannot estimate: anything that is not a current. A mass, buoyancy, centre-of-buoyancy,
thrust or drag-coefficient error, or an external push, shows up as an equivalent current (the
current that would make the same velocity change), not as a mass or a force: a hull 2% heavier than
the model's appears as a downward current of about 0.06 m/s (2.6 N against the heave drag), a plant
whose drag law differs as a current scaled and turned by that difference (in MuJoCo 0.15 m/s along
world x read as about (0.154, -0.028, -0.004) m/s; tests/test_estimator.py). It estimates a
translational, uniform current only (no rotation or shear of the flow), and takes the current's time
derivative as zero over a period (no Froude-Krylov force from its change). A current component along
a body axis whose drag is purely quadratic (sway: the Fossen linear sway damping is 0) is barely
observable while the relative flow along that axis is near zero: the Jacobian's column there vanishes
with the flow, and the estimate converges there only as fast as the error itself supplies a gradient.
That is why the default lambda is small: (1 mm/s of velocity noise / 0.3 m/s of expected current)^2
is 1e-5; at 1e-3 the sway component stalled 4 mm/s short on the model itself.

Cost: 7 calls of the compiled `held_steps` (4 RK4 substeps each) and a 3x3 solve, about 1 to 2 ms
an update (medians of 0.9 to 1.7 ms over runs on a shared 2-core x86_64 machine; the first call
loads the compiled code, tens of ms).

Settings (ObserverSettings): `time_constant` [s], `max_speed` [m/s], `damping` lambda [1, on
J^T J where J is in (m/s)/(m/s)], `fd_step` [m/s], `substeps` [1], `angular_weight` [m/rad].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from controller.model import UVMSModel


@dataclass(frozen=True)
class ObserverSettings:
    """Settings of CurrentObserver (units beside each)."""

    time_constant: float = 0.5  # s, first-order lag of the estimate behind the Gauss-Newton target
    max_speed: float = 1.0  # m/s, largest magnitude of the estimated extra current
    damping: float = 1e-5  # 1, Tikhonov lambda added to J^T J (J: (m/s) of residual per (m/s) of current)
    fd_step: float = 1e-3  # m/s, central finite-difference step of the current for the Jacobian
    substeps: int = 4  # 1, RK4 steps of the prediction over one period (4: the controller's rollouts' code)
    angular_weight: float = 0.0  # m/rad, weight of the hull's angular-velocity residual (0: linear only)

    def __post_init__(self) -> None:
        for name in ("time_constant", "max_speed", "damping", "fd_step"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"ObserverSettings.{name} = {value}; allowed: a finite number > 0")
        if self.substeps < 1:
            raise ValueError(f"ObserverSettings.substeps = {self.substeps}; allowed: an integer >= 1")
        if not np.isfinite(self.angular_weight) or self.angular_weight < 0:
            raise ValueError(f"ObserverSettings.angular_weight = {self.angular_weight}; allowed: >= 0")


class CurrentObserver:
    """Estimates the extra current [m/s, world] from consecutive measured states (module docstring)."""

    def __init__(self, model: UVMSModel, settings: ObserverSettings = ObserverSettings()):
        self.model, self.settings = model, settings
        n = model.n_joints
        self._rows = np.arange(6 + n, 9 + n) if settings.angular_weight == 0 else np.arange(6 + n, 12 + n)
        self._weights = np.ones(len(self._rows))
        self._weights[3:] = settings.angular_weight
        self._estimate = np.zeros(3)

    @property
    def estimate(self) -> np.ndarray:
        """The present estimate of the extra current [m/s, world] (a copy)."""
        return self._estimate.copy()

    def reset(self) -> None:
        """Forget the estimate (back to no extra current)."""
        self._estimate = np.zeros(3)

    def _predict(self, h_prev: np.ndarray, u_prev: np.ndarray, dt: float, current: np.ndarray) -> np.ndarray:
        """The weighted hull velocities the model predicts at the end of the period."""
        s = self.settings
        return self.model.held_steps(h_prev, u_prev, dt, s.substeps, vc=current)[self._rows] * self._weights

    def update(self, h_prev: np.ndarray, u_prev: np.ndarray, dt: float, h_now: np.ndarray,
               known_current: np.ndarray) -> np.ndarray:
        """One observer step: u_prev [N, N m] was held over dt [s] from the measured state h_prev to
        the measured state h_now; known_current [m/s, world] is the current the controller knows.
        Returns the updated estimate of the extra current [m/s, world]."""
        s = self.settings
        h_prev, u_prev, h_now = (np.asarray(a, float) for a in (h_prev, u_prev, h_now))
        known = np.asarray(known_current, float)
        if not (dt > 0 and np.all(np.isfinite(h_prev)) and np.all(np.isfinite(u_prev))
                and np.all(np.isfinite(h_now)) and np.all(np.isfinite(known))):
            return self.estimate
        c = known + self._estimate
        residual = h_now[self._rows] * self._weights - self._predict(h_prev, u_prev, dt, c)
        J = np.empty((len(self._rows), 3))
        for i, e in enumerate(s.fd_step * np.eye(3)):
            ahead, behind = self._predict(h_prev, u_prev, dt, c + e), self._predict(h_prev, u_prev, dt, c - e)
            J[:, i] = (ahead - behind) / (2 * s.fd_step)
        if not (np.all(np.isfinite(residual)) and np.all(np.isfinite(J))):
            return self.estimate
        delta = np.linalg.solve(J.T @ J + s.damping * np.eye(3), J.T @ residual)
        target = self._estimate + delta
        norm = float(np.linalg.norm(target))
        if norm > s.max_speed:
            target *= s.max_speed / norm
        gain = -np.expm1(-dt / s.time_constant)
        self._estimate = self._estimate + gain * (target - self._estimate)
        return self.estimate


__all__ = ["CurrentObserver", "ObserverSettings"]
