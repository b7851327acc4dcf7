"""Is Mode I's feasible set F empty? A certificate, not a solver failure (paper Alg. 3's test).

IPOPT fails on tight feasible problems and can hit its iteration cap on infeasible ones without
saying so, so a failed Mode I solve proves nothing. The test here has two stages:

1. Screen: roll the model out over the horizon under maximum braking (thrust against the hull's
   velocity, scaled to the thrusters' limits after an attitude hold; joints held at their
   posture). If every clearance
   at every node stays above the margin, that rollout is a point of F: feasible, certified.
2. Otherwise solve the minimum-violation problem (Mode I with an L1 slack on every clearance
   constraint, cost sum(slack)), started from that rollout (slacks just large enough, so the start
   is feasible). Its optimum is 0 exactly when F is non-empty, so F is declared empty when the
   minimum violation exceeds `tolerance` [m] (summed over nodes and bodies). The problem is not
   convex: a positive local minimum is strong evidence, not a proof, that F is empty (two starts
   gave 2.5 and 12.8 cm on the same unavoidable case). If IPOPT fails on this
   always-feasible problem, F is declared empty (the safe side: the strategy prepares for contact)
   and the certificate says so by an infinite violation.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from enum import Enum

import numpy as np

from controller.mode1 import ModeIOCP, ModeISettings, OCPSolution, SolverStatus
from controller.model import UVMSModel
from uvms.scene import Plane


class Verdict(Enum):
    FEASIBLE = "feasible"
    INFEASIBLE = "infeasible"


class Method(Enum):
    BRAKING_ROLLOUT = "braking rollout"
    MINIMUM_VIOLATION = "minimum violation"


@dataclass(frozen=True)
class Certificate:
    """The verdict on F and its evidence."""

    verdict: Verdict
    method: Method
    violation: float  # m: minimum total clearance violation (0 when the rollout certified F)
    rollout_clearance: float  # m: smallest clearance minus margin along the braking rollout
    solve_time: float  # s
    solution: OCPSolution | None  # the minimum-violation solution, when solved


class FeasibilityTest:
    """Decide F != {} for Mode I's OCP (same model, planes and settings)."""

    def __init__(self, model: UVMSModel, planes: Sequence[Plane], settings: ModeISettings | None = None,
                 tolerance: float = 1e-3):
        settings = settings or ModeISettings()
        self.model, self.settings, self.tolerance = model, settings, tolerance
        # Started cold from the rollout: a large initial barrier and no warm-start point work best
        # (with Mode I's warm-start options IPOPT hit 100 iterations on the unavoidable case).
        cold = replace(settings, max_iter=max(settings.max_iter, 300), ipopt_options={
            "warm_start_init_point": "no", "mu_init": 0.1, **settings.ipopt_options})
        self.problem = ModeIOCP(model, planes, cold, min_violation=True)
        p = model.params
        self._B = p.allocation_matrix()
        self._pinv = np.linalg.pinv(self._B)
        self._thrust_limit = np.array([t.force_range for t in p.thrusters])

    def braking_inputs(self, h: np.ndarray, posture: np.ndarray) -> np.ndarray:
        """Maximum braking with attitude hold. The thrusters first serve an attitude PD (level
        roll and pitch, heading and angular rates held; 20 N m/rad, 5 N m s/rad), and the largest
        force against the hull's body velocity that the remaining thruster range allows is added.
        Joint torques by computed torque: those that make the joints' acceleration zero under this
        thrust (M [a_hull; 0] + b = [B u; tau]), plus a gentle PD to `posture` [rad] (1 N m/rad,
        0.1 N m s/rad: stable when held over a 0.1 s interval), within the torque limits."""
        n, nt = self.model.n_joints, self.model.params.n_thrusters
        v, w = h[6 + n:9 + n], h[9 + n:12 + n]
        hold = np.concatenate([np.zeros(3), -20.0 * np.array([h[3], h[4], 0.0]) - 5.0 * w])
        lo_t, hi_t = self._thrust_limit[:, 0], self._thrust_limit[:, 1]
        base = np.clip(self._pinv @ hold, lo_t, hi_t)
        brake = self._pinv @ np.concatenate([-v, np.zeros(3)])
        room = np.where(brake > 0, hi_t - base, lo_t - base)
        moving = np.abs(brake) > 1e-12
        scale = np.min(room[moving] / brake[moving]) if np.any(moving) else 0.0
        thrust = base + max(scale, 0.0) * brake
        lo, hi = self.model.params.input_bounds()
        M = np.asarray(self.model.mass_matrix(h))
        b = np.asarray(self.model.bias(h, np.zeros(3), np.zeros(3))).ravel()
        a_hull = np.linalg.solve(M[:6, :6], self._B @ thrust - b[:6])
        tau = M[6:, :6] @ a_hull + b[6:] + 1.0 * (posture - h[6:6 + n]) - 0.1 * h[12 + n:]
        tau = np.clip(tau, lo[nt:], hi[nt:])
        return np.concatenate([thrust, tau])

    def braking_rollout(self, h0: np.ndarray, current: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """States (N+1, ns) at the horizon's nodes and inputs (N, nu) under `braking_inputs`, held
        over each interval and integrated by RK4 in 4 substeps."""
        s = self.settings
        hs, us = [np.asarray(h0, float)], []
        posture = hs[0][6:6 + self.model.n_joints]
        for _ in range(s.horizon):
            u = self.braking_inputs(hs[-1], posture)
            h = hs[-1]
            for _ in range(4):
                h = self.model.step(h, u, s.dt / 4, vc=current)
            hs.append(h)
            us.append(u)
        return np.array(hs), np.array(us)

    def __call__(self, h0: np.ndarray, h_ref: np.ndarray, current: np.ndarray | None = None,
                 previous: OCPSolution | None = None) -> Certificate:
        t0 = time.perf_counter()
        hs, us = self.braking_rollout(h0, current)
        clearance = min(float(np.asarray(self.problem._clearance(h)).min()) for h in hs[1:])
        margin = clearance - self.settings.distance_margin
        if margin >= 0:
            return Certificate(Verdict.FEASIBLE, Method.BRAKING_ROLLOUT, 0.0, margin, time.perf_counter() - t0, None)
        sol = self.problem.solve(h0, h_ref, current, previous, guess=self.problem.guess_from_rollout(hs, us))
        violation = float(np.sum(sol.slack)) if sol.status is SolverStatus.SUCCESS else np.inf
        verdict = Verdict.FEASIBLE if violation <= self.tolerance else Verdict.INFEASIBLE
        return Certificate(verdict, Method.MINIMUM_VIOLATION, violation, margin, time.perf_counter() - t0, sol)
