"""An observer of what the controller does not know about the water and the hull: the current and
the hull's weight in water, from measured states alone.

What it estimates: the extra horizontal current (c_x, c_y) [m/s, world] that, added to the current
the controller knows, and the hull's extra weight in water W [N, downwards, at its CoM] that, added
to its parameters', make the controller's own model (controller.model.UVMSModel) reproduce the
measured motion of the hull over each control period. A vertical current is taken as zero: a
vertical drift of the hull is read as weight, which is what a hull heavier or lighter than its model
(a payload, a trim error, a leak) makes, while ocean currents are horizontal. A heavy hull read as a
downward current instead misleads every plan that moves the hull vertically, since drag then pushes
it by the relative velocity and the weight does not (experiments/wide_known_7100: knowing the weight
and the current is what the wide mismatch's failures need).

Method: one damped Gauss-Newton step per control period on the hull's body velocity, then a
filter with a growing memory at first and a first-order lag after. The unknowns
theta = (c_x, c_y, W / WEIGHT_UNIT) are scaled so that their Jacobian columns are of one size
(10 N of weight change a period's velocity about as much as 0.1 m/s of current).
From the measured state h_prev and the input u_prev held over dt, the model predicts
h_pred(theta) = `held_steps(h_prev, u_prev, dt, substeps, vc=water(known + c, W))` (under a latency the
previous input first, for the delay, then u_prev, the substeps shared out by duration). The residual r
is the measured minus the predicted hull linear body velocity [m/s] (and, with `angular_weight` > 0,
the angular one [rad/s] times that weight [m/rad]); its Jacobian J = dr/dtheta (3x3 or 6x3) is taken
by central finite differences of the prediction about the present estimate (6 calls of the compiled
`held_steps`, so no code beyond the model's own is compiled). The damped least-squares step
    delta = (J^T J + lambda I)^-1 J^T r
is bounded for any J, singular or tiny ones included (|delta| <= |r| / (2 sqrt(lambda))). A step
that does not lower the residual's norm is retried with lambda 100 times larger, up to LM_TRIALS
dampings (Levenberg-Marquardt), and an update none of whose steps lowers it keeps the estimate as
its target: at zero relative flow the sway drag is flat in the current (purely quadratic), so the
first undamped step there is a guess, not an estimate (0.9 m/s off in MuJoCo's first period). The
estimate moves towards the accepted target by the k-th update's gain
    theta <- theta + max(1 / k, 1 - exp(-dt / tau)) * (clip(theta + delta) - theta):
about the mean of all targets so far while they are fewer than about tau / dt (the first update
takes its target whole, so that a vehicle that meets a wall within a second of starting plans with
an estimate), then a first-order lag of time constant tau,
where clip scales a current longer than `max_speed` back onto that circle and limits |W| to
`max_weight`. The estimate is thus always within those bounds (a convex combination of points of a
convex set) and never NaN: a non-finite state or prediction leaves it unchanged. One step per period
suffices because the prediction starts from the measured state each time (no model state drifts)
and the filter averages many such steps; on the model itself only the filter's lag remains
(tests/test_estimator.py).
It learns only while the hull moves through the known water slower than `learning_speed` (0.5 m/s)
at both states: faster, the model's drag law and the plant's part, and the gap reads as weight.
It also skips periods over which the hull's world velocity changes faster than
`learning_acceleration` (0.5 m/s^2): a mass and added mass the model does not know then act, and read
as weight too.
Why the velocity residual: a current acts on the hull through the relative velocity in drag and
added-mass forces, and a weight as a force, i.e. both on accelerations; the change of velocity over
a period is the measurable effect, and positions carry no more information one period ahead. The
angular residual is off by default: a uniform current exerts little moment, and what moment the
plant has (MuJoCo's Kutta lift and Munk moment, the links' ellipsoid fit) is where the two fluid
models differ most (with a weight of 1 m/rad the MuJoCo estimate moved by 3 mm/s, no closer to the
injected current).

What it cannot estimate: anything else. An inertia, centre-of-buoyancy, thrust or drag-coefficient
error, or an external push, shows up as the current and weight that would make the same velocity
change: a plant whose drag law differs as a current scaled and turned by that difference (in MuJoCo
0.15 m/s along world x reads as about (0.155, -0.028) m/s; tests/test_estimator.py), a vertical drag
difference as a weight. It estimates a horizontal, uniform current only (no rotation or shear of the
flow), and takes the current's time derivative as zero over a period (no Froude-Krylov force from
its change). A current component along a body axis whose drag is purely quadratic (sway: the Fossen
linear sway damping is 0) is barely observable while the relative flow along that axis is near zero:
the Jacobian's column there vanishes with the flow, and the estimate converges there only as fast as
the error itself supplies a gradient. That is why the default lambda is small: (1 mm/s of velocity
noise / 0.3 m/s of expected current)^2 is 1e-5; at 1e-3 the sway component stalled 4 mm/s short on
the model itself.

Cost: 8 to 11 calls of the compiled `held_steps` (4 RK4 substeps each) and a 3x3 solve or more,
about 1 to 2 ms an update (medians of 1.0 to 2.2 ms over runs on a shared 2-core x86_64 machine; the
first call loads the compiled code, tens of ms).

Settings (ObserverSettings): `time_constant` [s], `max_speed` [m/s], `max_weight` [N], `damping`
lambda [1, on J^T J where J is in (m/s) per unit of theta], `fd_step` [unit of theta: m/s, or
WEIGHT_UNIT N], `substeps` [1], `angular_weight` [m/rad].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from controller.model import UVMSModel, water

WEIGHT_UNIT = 10.0  # N of extra hull weight per unit of the observer's third unknown
LM_TRIALS = 4  # dampings tried per update: lambda, 100 lambda, ... (Levenberg-Marquardt)


@dataclass(frozen=True)
class ObserverSettings:
    """Settings of CurrentObserver (units beside each)."""

    time_constant: float = 0.5  # s, first-order lag of the estimate behind the Gauss-Newton target
    max_speed: float = 1.0  # m/s, largest magnitude of the estimated extra current
    max_weight: float = 50.0  # N, largest magnitude of the estimated extra hull weight in water
    damping: float = 1e-5  # 1, Tikhonov lambda added to J^T J (J: (m/s) of residual per unit of theta)
    fd_step: float = 1e-3  # m/s or WEIGHT_UNIT N, central finite-difference step of theta for the Jacobian
    substeps: int = 4  # 1, RK4 steps of the prediction over one period (4: the controller's rollouts' code)
    angular_weight: float = 0.0  # m/rad, weight of the hull's angular-velocity residual (0: linear only)
    # m/s, or None (always): update only while the hull moves slower than this through the known
    # water at both states. The model's and the plant's drag laws part with speed: in a 1.2 m/s
    # approach the observer read 11-23 N of weight that the default mismatch cannot give, and
    # wall-oblique's hull came closer (experiments/observer_learning_speed: on held-out seeds the
    # hull further off in 39 runs, closer in 21, p = 0.027; station keeping, at 0.3-0.5 m/s, unchanged)
    learning_speed: float | None = 0.5
    # m/s^2, or None (always): update only while the hull's world velocity changes by less than this
    # times the period over it. Braking hard (1-5 m/s^2) the observer read 6-29 N of weight where the
    # default mismatch gives about 4 N (experiments/observer_gated_latency). Without a delay that
    # reading moved no hull (experiments/observer_learning_acceleration: the final task error at 5 s
    # larger in 41 of 48 differing wall runs); under one it made Mode I late, and with this gate the
    # observer is updated there too (experiments/observer_latency_accel)
    learning_acceleration: float | None = 0.5

    def __post_init__(self) -> None:
        for name in ("time_constant", "max_speed", "max_weight", "damping", "fd_step"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"ObserverSettings.{name} = {value}; allowed: a finite number > 0")
        if self.substeps < 1:
            raise ValueError(f"ObserverSettings.substeps = {self.substeps}; allowed: an integer >= 1")
        if self.learning_speed is not None and not (np.isfinite(self.learning_speed) and self.learning_speed > 0):
            raise ValueError(f"ObserverSettings.learning_speed = {self.learning_speed}; allowed: a finite number > 0 "
                             "or None")
        if self.learning_acceleration is not None and not (np.isfinite(self.learning_acceleration)
                                                           and self.learning_acceleration > 0):
            raise ValueError(f"ObserverSettings.learning_acceleration = {self.learning_acceleration}; allowed: a "
                             "finite number > 0 or None")
        if not np.isfinite(self.angular_weight) or self.angular_weight < 0:
            raise ValueError(f"ObserverSettings.angular_weight = {self.angular_weight}; allowed: >= 0")


class CurrentObserver:
    """Estimates the extra horizontal current [m/s, world] and the hull's extra weight in water [N]
    from consecutive measured states (module docstring)."""

    def __init__(self, model: UVMSModel, settings: ObserverSettings = ObserverSettings()):
        self.model, self.settings = model, settings
        n = model.n_joints
        self._rows = np.arange(6 + n, 9 + n) if settings.angular_weight == 0 else np.arange(6 + n, 12 + n)
        self._weights = np.ones(len(self._rows))
        self._weights[3:] = settings.angular_weight
        self._theta = np.zeros(3)  # c_x [m/s], c_y [m/s], W / WEIGHT_UNIT
        self._updates = 0  # updates since the last reset

    @staticmethod
    def _water(theta: np.ndarray) -> np.ndarray:
        return water([theta[0], theta[1], 0.0], theta[2] * WEIGHT_UNIT)

    @property
    def estimate(self) -> np.ndarray:
        """The present estimate as the model's `vc` values (controller.model.water): the extra
        current [m/s, world; vertical 0] and the extra hull weight in water [N]."""
        return self._water(self._theta)

    @property
    def updates(self) -> int:
        """The updates since the last reset."""
        return self._updates

    def reset(self) -> None:
        """Forget the estimate (back to no extra current and no extra weight)."""
        self._theta = np.zeros(3)
        self._updates = 0

    def _predict(self, h_prev: np.ndarray, inputs: Sequence[tuple[np.ndarray, float]], dt: float,
                 known: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """The weighted hull velocities the model predicts at the end of the period, each input held
        for its seconds in turn (`substeps` RK4 steps over the period, shared out by duration)."""
        s = self.settings
        vc, h = known + self._water(theta), h_prev
        for u, seconds in inputs:
            h = self.model.held_steps(h, u, seconds, max(1, round(s.substeps * seconds / dt)), vc=vc)
        return h[self._rows] * self._weights

    def _world_velocity(self, h: np.ndarray) -> np.ndarray:
        """The hull's linear velocity [m/s, world] at state h."""
        n = self.model.n_speeds
        return np.asarray(self.model.rotation(h), float) @ h[n:n + 3]

    def _water_speed(self, h: np.ndarray, known: np.ndarray) -> float:
        """The hull's speed [m/s] through the known water at state h."""
        return float(np.linalg.norm(self._world_velocity(h) - known[:3]))

    def _clip(self, theta: np.ndarray) -> np.ndarray:
        s, out = self.settings, theta.copy()
        norm = float(np.linalg.norm(out[:2]))
        if norm > s.max_speed:
            out[:2] *= s.max_speed / norm
        out[2] = np.clip(out[2], -s.max_weight / WEIGHT_UNIT, s.max_weight / WEIGHT_UNIT)
        return out

    def update(self, h_prev: np.ndarray, u_prev: np.ndarray, dt: float, h_now: np.ndarray,
               known_current: np.ndarray, before: tuple[np.ndarray, float] | None = None) -> np.ndarray:
        """One observer step: u_prev [N, N m] was held over dt [s] from the measured state h_prev to
        the measured state h_now; known_current [m/s, world] is the current the controller knows.
        `before` (an input and seconds, under a latency): that input acted first, for those seconds
        of dt, and u_prev for the rest. Returns the updated `estimate`."""
        s = self.settings
        h_prev, u_prev, h_now = (np.asarray(a, float) for a in (h_prev, u_prev, h_now))
        known = water(np.asarray(known_current, float))
        inputs = [(u_prev, dt)]
        if before is not None and before[1] > 0.0:
            u_before, first = np.asarray(before[0], float), float(before[1])
            if not (np.all(np.isfinite(u_before)) and first <= dt):
                return self.estimate
            inputs = [(u_before, first)] + ([(u_prev, dt - first)] if dt - first > 1e-9 else [])
        if not (dt > 0 and np.all(np.isfinite(h_prev)) and np.all(np.isfinite(u_prev))
                and np.all(np.isfinite(h_now)) and np.all(np.isfinite(known))):
            return self.estimate
        if s.learning_speed is not None and max(self._water_speed(h, known) for h in (h_prev, h_now)) > \
                s.learning_speed:
            return self.estimate
        if s.learning_acceleration is not None and np.linalg.norm(
                self._world_velocity(h_now) - self._world_velocity(h_prev)) > s.learning_acceleration * dt:
            return self.estimate
        theta = self._theta
        residual = h_now[self._rows] * self._weights - self._predict(h_prev, inputs, dt, known, theta)
        J = np.empty((len(self._rows), 3))
        for i, e in enumerate(s.fd_step * np.eye(3)):
            ahead = self._predict(h_prev, inputs, dt, known, theta + e)
            behind = self._predict(h_prev, inputs, dt, known, theta - e)
            J[:, i] = (ahead - behind) / (2 * s.fd_step)
        if not (np.all(np.isfinite(residual)) and np.all(np.isfinite(J))):
            return self.estimate
        target, worst = theta, float(residual @ residual)
        for damping in s.damping * 10.0 ** np.arange(0, 2 * LM_TRIALS, 2):
            delta = np.linalg.solve(J.T @ J + damping * np.eye(3), J.T @ residual)
            trial = self._clip(theta + delta)
            r = h_now[self._rows] * self._weights - self._predict(h_prev, inputs, dt, known, trial)
            if np.all(np.isfinite(r)) and float(r @ r) < worst:
                target = trial
                break
        self._updates += 1
        gain = max(1.0 / self._updates, -np.expm1(-dt / s.time_constant))
        self._theta = theta + gain * (target - theta)
        return self.estimate


__all__ = ["WEIGHT_UNIT", "CurrentObserver", "ObserverSettings"]
