"""Is Mode I's feasible set F empty? A certificate, not a solver failure (paper Alg. 3's test).

IPOPT fails on tight feasible problems and can hit its iteration cap on infeasible ones without
saying so, so a failed Mode I solve proves nothing. The test here has two stages:

1. Screens: roll the model out over the horizon under maximum braking (thrust against the hull's
   velocity, scaled to the thrusters' limits after an attitude hold; joints held at their
   posture: controller.rollouts.BrakingPolicy); when the caller gives them, under the previous
   Mode I plan shifted by one interval, and then under a fresh Mode I plan (the caller's solve,
   asked for only when the other screens fail). If every clearance at every node of a rollout
   stays above the margin (and the plan's inputs and joint angles within their bounds), that
   rollout is a point of F: feasible, certified. Once the braking rollout has failed the caller is
   asked whether the answer matters (`needed`); if not, nothing more is solved. Then, the fresh plan
   continued by Mode I's SQP with a line search (the caller's `refine`, up to
   `CertificateSettings.refine_iterations`), stopped at its first iterate that passes that test:
   Mode I's real-time plans near a wall violate its dynamics by tens of newtons, so their
   re-simulation rarely passes, while a few globalized iterations usually do.
2. Otherwise solve the minimum-violation problem (Mode I with an L1 slack on every clearance
   constraint, cost sum(slack)) from the fresh Mode I plan, else from the braking rollout. Its
   optimum is 0 exactly when F is non-empty, so F is declared empty when the minimum violation
   exceeds `CertificateSettings.tolerance` [m] (summed over nodes and bodies). IPOPT stops at its
   first iterate whose inputs, re-simulated by RK4 from the measured state, pass the screens' test
   (`is_witness`), and the certificate carries that re-simulated plan. The problem is not convex: a
   positive local minimum is strong evidence, not a proof. An iterate feasible at IPOPT's cap counts
   with its slack sum (an upper bound); if IPOPT fails on this always-feasible problem, F is
   declared empty (the safe side) with an infinite violation. Evidence: docs/decisions.md.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from enum import Enum

import numpy as np

from controller.mode1 import ModeIOCP, ModeISettings, OCPSolution
from controller.model import UVMSModel
from controller.rollouts import BrakingPolicy, simulate
from controller.transcription import SolverStatus
from uvms.scene import Plane


class Verdict(Enum):
    FEASIBLE = "feasible"
    INFEASIBLE = "infeasible"
    UNDECIDED = "not certified by the screens (the minimum-violation problem was not asked)"


class Method(Enum):
    BRAKING_ROLLOUT = "braking rollout"
    PREVIOUS_PLAN = "previous plan, shifted"
    MODE_I_PLAN = "Mode I's plan"
    REFINED_PLAN = "Mode I's plan, continued by the SQP with a line search"
    MINIMUM_VIOLATION = "minimum violation"
    SCREENS = "screens only"


@dataclass(frozen=True)
class CertificateSettings:
    """The minimum-violation problem's settings."""

    tolerance: float = 1e-3  # m: F counts as empty above this summed clearance violation
    max_iter: int = 100  # IPOPT's cap (an iterate feasible at it counts with its slack sum)
    mu_init: float = 0.1  # IPOPT's initial barrier (a cold start from a rollout: a large one works best)
    refine_iterations: int = 8  # the fresh plan's further SQP iterations before the problem (0: none)


@dataclass(frozen=True)
class Certificate:
    """The verdict on F and its evidence."""

    verdict: Verdict
    method: Method
    violation: float  # m: minimum total clearance violation (0 when a screen certified F; nan: UNDECIDED)
    rollout_clearance: float  # m: smallest clearance minus margin along the braking rollout
    solve_time: float  # s
    solution: OCPSolution | None  # the minimum-violation solution (its witness's states when stopped at one)
    rollout: np.ndarray  # (N+1, ns) the braking rollout's states
    rollout_inputs: np.ndarray | None = None  # (N, nu) the braking rollout's inputs


class FeasibilityTest:
    """Decide F != {} for Mode I's OCP (same model, planes and settings)."""

    def __init__(self, model: UVMSModel, planes: Sequence[Plane], settings: ModeISettings | None = None,
                 certificate: CertificateSettings = CertificateSettings()):
        settings = settings or ModeISettings()
        self.model, self.settings, self.certificate = model, settings, certificate
        self.tolerance = certificate.tolerance
        self._witness: np.ndarray | None = None  # the states of the last witness
        self._clearances: dict = {}  # min_clearance's mapped clearance functions, by number of nodes
        cold = replace(settings, max_iter=certificate.max_iter, ipopt_options={
            "warm_start_init_point": "no", "mu_init": certificate.mu_init, **settings.ipopt_options})
        self.problem = ModeIOCP(model, planes, cold, min_violation=True, stop=self.is_witness)
        self.braking = BrakingPolicy(model)
        self.braking.compiled_rollout(settings.horizon, 4, False)  # compiled now, not at the first step

    def limit_inputs(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Replace the input bounds of every problem and rollout (e.g. known-failed thrusters: both 0)."""
        self.problem.limit_inputs(lo, hi)
        self.braking.limit_thrust(lo, hi)

    def braking_rollout(self, h0: np.ndarray, current: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """States (N+1, ns) at the horizon's nodes and inputs (N, nu) under maximum braking with
        the joints held at their posture (controller.rollouts.BrakingPolicy), held over each
        interval and integrated by RK4 in 4 substeps."""
        s = self.settings
        h0 = np.asarray(h0, float)
        return self.braking.rollout(h0, h0[6:6 + self.model.n_joints], s.dt, s.horizon, current=current)

    def min_clearance(self, hs: np.ndarray) -> float:
        """Smallest clearance [m] over the nodes hs[1:] (states (N+1, ns)): the clearance function
        mapped over the nodes, one call (its values, without the per-call cost of N calls)."""
        n = len(hs) - 1
        if n not in self._clearances:
            self._clearances[n] = self.problem._clearance.map(n)
        return float(np.asarray(self._clearances[n](np.asarray(hs[1:], float).T)).min())

    def plan_is_feasible(self, hs: np.ndarray, us: np.ndarray) -> bool:
        """Whether a rollout (states (N+1, ns) from the measured state, inputs (N, nu)) is a point of
        F: clearances above the margin at every node, inputs and joint angles within bounds."""
        return self.problem.plan_within_bounds(hs, us) and self.min_clearance(hs) >= self.settings.distance_margin

    def is_witness(self, sol: OCPSolution, p: np.ndarray) -> bool:
        """Whether the minimum-violation iterate's inputs, re-simulated from h0 by the model's RK4, pass
        `plan_is_feasible` (p = (h0, h_ref, current)): a point of F by the screens' own test,
        whatever the iterate's slacks and dynamics residuals. Keeps the re-simulated states."""
        ns = self.model.n_states
        self._witness = self.resimulated_if_feasible(p[:ns], sol.u, p[2 * ns:])
        return self._witness is not None

    def resimulated_if_feasible(self, h0: np.ndarray, us: np.ndarray, current: np.ndarray | None = None
                                ) -> np.ndarray | None:
        """The states (N+1, ns) of inputs us (N, nu) re-simulated from h0 by the model's RK4 when
        they pass `plan_is_feasible`, else None."""
        hs = simulate(self.model, h0, us, self.settings.dt, current=current)
        return hs if self.plan_is_feasible(hs, us) else None

    def continued(self, ocp: ModeIOCP, h0: np.ndarray, h_ref: np.ndarray, current: np.ndarray | None,
                  start: np.ndarray) -> tuple[np.ndarray, OCPSolution] | None:
        """Mode I's plan from the primal start `start` (ocp's layout) continued by ocp's SQP with a
        line search for up to `CertificateSettings.refine_iterations`, stopped at its first iterate
        whose inputs re-simulate from h0 to a point of F: (those states (N+1, ns), the STOPPED
        solution), else None (also when ocp is not solved by the SQP)."""
        n = self.certificate.refine_iterations
        if n < 1 or ocp.sqp is None:
            return None
        witness: dict = {}

        def passes(u: np.ndarray) -> bool:
            witness["h"] = self.resimulated_if_feasible(h0, u, current)
            return witness["h"] is not None

        sol = ocp.solve(h0, h_ref, current, guess=start, stop=passes,
                        sqp=replace(ocp.settings.sqp, max_iter=n, line_search=True, real_time=False))
        return (witness["h"], sol) if sol.status is SolverStatus.STOPPED else None

    def __call__(self, h0: np.ndarray, h_ref: np.ndarray, current: np.ndarray | None = None,
                 previous: OCPSolution | None = None, plan: tuple[np.ndarray, np.ndarray] | None = None,
                 fresh: Callable[[], tuple[np.ndarray, np.ndarray] | None] | None = None,
                 needed: Callable[[Certificate], bool] | None = None,
                 refine: Callable[[Certificate], tuple[np.ndarray, np.ndarray] | None] | None = None
                 ) -> Certificate:
        """The verdict for the measured state h0. `plan`: the previous Mode I plan shifted by one
        interval, as (states re-simulated from h0, inputs): the second screen. `fresh`: called
        when the screens before it fail, returns a new Mode I plan in the same form (or None): the
        third. `needed`: called with an UNDECIDED certificate when the braking rollout fails, before
        the other screens; when it returns False (the caller's decision does not depend on the
        answer) that certificate is returned, with neither those screens nor the minimum-violation
        problem solved. `refine`: called with it when the screens fail, returns a further plan in
        the same form (the fresh one continued) or None: the fourth screen."""
        t0 = time.perf_counter()
        hs, us = self.braking_rollout(h0, current)
        margin = self.min_clearance(hs) - self.settings.distance_margin

        def found(method: Method) -> Certificate:
            return Certificate(Verdict.FEASIBLE, method, 0.0, margin, time.perf_counter() - t0, None, hs, us)

        if margin >= 0:
            return found(Method.BRAKING_ROLLOUT)
        undecided = Certificate(Verdict.UNDECIDED, Method.SCREENS, np.nan, margin, time.perf_counter() - t0, None,
                                hs, us)
        if needed is not None and not needed(undecided):
            return replace(undecided, solve_time=time.perf_counter() - t0)
        if plan is not None and self.plan_is_feasible(*plan):
            return found(Method.PREVIOUS_PLAN)
        candidate = fresh() if fresh is not None else None
        if candidate is not None and self.plan_is_feasible(*candidate):
            return found(Method.MODE_I_PLAN)
        refined = refine(undecided) if refine is not None else None
        if refined is not None and self.plan_is_feasible(*refined):
            return found(Method.REFINED_PLAN)
        start = candidate if candidate is not None else (hs, us)
        sol = self.problem.solve(h0, h_ref, current, previous, guess=self.problem.guess_from_rollout(*start))
        return self.judge(sol, margin, time.perf_counter() - t0, hs, us)

    def judge(self, sol: OCPSolution, rollout_clearance: float, seconds: float, hs: np.ndarray,
              us: np.ndarray) -> Certificate:
        """The verdict of a minimum-violation solution: F empty when its slack sum exceeds the
        tolerance, or when IPOPT could not use its solve (violation inf). hs, us: the braking rollout.
        A witness is a point of F: violation 0, its plan the re-simulated states."""
        if sol.status is SolverStatus.STOPPED:
            sol, violation = replace(sol, h=self._witness), 0.0
        else:
            violation = float(np.sum(sol.slack)) if sol.status.usable else np.inf
        verdict = Verdict.FEASIBLE if violation <= self.tolerance else Verdict.INFEASIBLE
        return Certificate(verdict, Method.MINIMUM_VIOLATION, violation, rollout_clearance, seconds, sol, hs, us)
