"""A plan turned into a feedback policy: time-varying LQR gains along it.

An NMPC's plan (states h_k, inputs u_k, intervals dt) is what the controller commits to should its
next answers come too late (validation.closed_loop, strict real time). Applied open loop, the
plan's thrust and joint torques drift from the state that the plant actually reaches; with the
gains K_k of a finite-horizon LQR on the model's RK4 step linearized along the plan, row k's input
is u_k + K_k (h - h_k) (clipped by the plant), which steers back towards the planned states.

Linearization: forward differences of the compiled RK4 step (controller.model.compiled_rk4; all
1 + n_s + n_u perturbed steps of a node in one mapped C call), at `every`-th node and held between
(a symbolic Jacobian compiles for minutes; through CasADi's virtual machine it costs 8 ms a node).
Weights by Bryson's rule: each state error and input divided by what is acceptable
(`FeedbackScales`), so Q = diag(1/scale^2), R = diag(1/limit^2) with the thrusters' and joints'
limits of the parameter file; the terminal weight is Q. Dead thrusters get no gain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from controller.codegen import NumpyCall
from controller.model import UVMSModel

RELATIVE_STEP = 1e-6  # forward differences: step per unit of the entry's magnitude (at least this absolute)


@dataclass(frozen=True)
class FeedbackScales:
    """The state errors the feedback treats as equally bad (Bryson's rule), and where it linearizes."""

    position: float = 0.05  # m, the hull's
    angle: float = 0.1  # rad, the hull's Euler angles
    joint: float = 0.1  # rad
    speed: float = 0.1  # m/s, the hull's body-frame linear speed
    rate: float = 0.2  # rad/s, the hull's angular and the joints' rates
    every: int = 4  # linearize at every this-many-th node of the plan, held between


class PlanFeedback:
    """TV-LQR gains along a plan of the model (module docstring)."""

    def __init__(self, model: UVMSModel, scales: FeedbackScales = FeedbackScales()):
        self.model, self.scales = model, scales
        n, ns, nu = model.n_joints, model.n_states, model.n_inputs
        self._batch = NumpyCall(model.compiled_rk4().f.map(1 + ns + nu))
        q = np.concatenate([np.full(3, scales.position), np.full(3, scales.angle), np.full(n, scales.joint),
                            np.full(3, scales.speed), np.full(3 + n, scales.rate)])
        self.Q = np.diag(1.0 / q**2)
        lo, hi = model.params.input_bounds()
        self.R = np.diag(1.0 / np.maximum(np.abs(lo), np.abs(hi)) ** 2)

    def linearized(self, h: np.ndarray, u: np.ndarray, vc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """A = d h_next / d h, B = d h_next / d u of one RK4 step of dt [s] from h under u held, by
        forward differences."""
        ns, nu = self.model.n_states, self.model.n_inputs
        m = 1 + ns + nu
        x = np.concatenate([np.asarray(h, float), np.asarray(u, float)])
        step = RELATIVE_STEP * np.maximum(1.0, np.abs(x))
        X = np.tile(x[:, None], (1, m))
        X[np.arange(ns + nu), 1 + np.arange(ns + nu)] += step
        vc = np.asarray(vc, float)
        out = self._batch(X[:ns].ravel(order="F"), X[ns:].ravel(order="F"), np.zeros(6 * m),
                          np.tile(np.eye(3).ravel(), m), np.tile(vc, m), np.zeros(3 * m),
                          np.full(m, float(dt)))[0].reshape(ns, m, order="F")
        J = (out[:, 1:] - out[:, :1]) / step
        return J[:, :ns].copy(), J[:, ns:].copy()

    def gains(self, h_pred: np.ndarray, u_pred: np.ndarray, dt: float, vc: np.ndarray,
              dead: tuple[int, ...] = ()) -> np.ndarray:
        """(N, nu, ns) gains K_k of the finite-horizon LQR along the plan (h_pred (N+1, ns), u_pred
        (N, nu), intervals dt [s], water vc): row k's input is u_k + K_k (h - h_k); dead thrusters'
        rows are zero."""
        N = len(u_pred)
        P = self.Q.copy()
        K = np.zeros((N, self.model.n_inputs, self.model.n_states))
        lin: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        for k in range(N - 1, -1, -1):
            node = k - k % max(self.scales.every, 1)
            if node not in lin:
                A, B = self.linearized(h_pred[node], u_pred[node], vc, dt)
                B[:, list(dead)] = 0.0
                lin[node] = (A, B)
            A, B = lin[node]
            BP = B.T @ P
            K[k] = -np.linalg.solve(self.R + BP @ B, BP @ A)
            P = self.Q + A.T @ P @ (A + B @ K[k])
            P = 0.5 * (P + P.T)
        return K


def references(h_pred: np.ndarray, n_rows: int, dt: float, lead: float) -> np.ndarray:
    """(n_rows, ns): for committed row k >= 1, the planned state `lead` [s] before node k (the state
    the plant should be in when row k's step samples it, its input acting `lead` later), linear
    between the plan's nodes; row 0 (the input returned, never committed) is node 0."""
    frac = 1.0 - min(max(lead / dt, 0.0), 1.0)
    return np.array([h_pred[0]] + [(1.0 - frac) * h_pred[k - 1] + frac * h_pred[k] for k in range(1, n_rows)])
