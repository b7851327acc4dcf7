"""Is Mode I's feasible set F empty? A certificate, not a solver failure (paper Alg. 3's test).

IPOPT fails on tight feasible problems and can hit its iteration cap on infeasible ones without
saying so, so a failed Mode I solve proves nothing. The test here has two stages:

1. Screens: roll the model out over the horizon under maximum braking (thrust against the hull's
   velocity, scaled to the thrusters' limits after an attitude hold; joints held at their
   posture: controller.rollouts.BrakingPolicy); when the caller gives them, under the previous
   Mode I plan shifted by one interval, and then under a fresh Mode I plan (the caller's solve,
   asked for only when the other screens fail). If every clearance at every node of a rollout
   stays above the margin (and the plan's inputs and joint angles within their bounds), that
   rollout is a point of F: feasible, certified.
   Optional (`search_iterations` > 0; off by default): a last screen, a plan of Mode I's SQP
   globalized by a line search (controller.sqp), started from the previous plan shifted (else
   from the braking rollout), a point of F when it satisfies the OCP's constraints. It finds
   feasible plans that the real-time SQP's full steps lose, in about 0.2 s where the
   minimum-violation problem takes 0.5-2.5 s, and it removes false 'unavoidable' verdicts where
   IPOPT fails on the minimum-violation problem. It is off because, in MuJoCo, the better verdicts
   keep Mode I on plans at the margin until F empties with the hull so close that Mode II has no
   time to deploy the arm: wall-headon without mismatch then ends with an arm link on the wall
   (13.7 N s) instead of I > II > III > I (the note on issue 4).
2. Otherwise solve the minimum-violation problem (Mode I with an L1 slack on every clearance
   constraint, cost sum(slack)), started from the fresh Mode I plan when there is one, else from
   that rollout (slacks just large enough, so the start is feasible). Its optimum is 0 exactly when
   F is non-empty, so F is declared empty when the minimum violation exceeds `tolerance` [m]
   (summed over nodes and bodies). By default (Stop.WITNESS) IPOPT stops at its first iterate whose
   inputs, re-simulated by RK4 from the measured state, pass the screens' test (`is_witness`): a
   point of F by the screens' own standard, whatever the iterate's slacks and dynamics residuals;
   the certificate then carries that re-simulated plan. An interior-point iterate keeps every
   slack near the barrier parameter, so waiting for the slacks to sum to the tolerance (Stop.SLACK,
   the fifth session's stop, `proves_f`) means waiting for the barrier to fall to about 1e-6.
   Mode I's pitch bound (ModeISettings.pitch_limit) keeps the iterates off the Euler angles'
   singularity, where they used to wander. On 210 problems recorded in 17 MuJoCo runs
   (bench/results/min_violation_stop.md; solve times median / p95 / max): without the bound or a
   stop, 40 'unavoidable' (nearly all at the iteration cap), 132 iterations median, 25 s at most;
   with the bound, 2 'unavoidable', 84 iterations, 0.63 / 1.28 / 2.5 s; with the slack stop too,
   the same verdicts in 77; with the witness stop from the braking rollout, 26; from Mode I's plan
   (the default), the same verdicts in 3 iterations median (43 p95), 0.05 / 0.52 / 3.8 s (the
   maximum: the two 'unavoidable' ones, at the cap). The problem is not
   convex: a positive local minimum is strong evidence, not a proof, that F is empty (two starts
   gave 2.5 and 12.8 cm on the same unavoidable case). An iterate that IPOPT leaves feasible at its
   iteration cap counts with its slack sum (an upper bound on the minimum). If IPOPT fails on this
   always-feasible problem, F is declared empty (the safe side: the strategy prepares for contact)
   and the certificate says so by an infinite violation. Such failures were the rule where a
   box-like body faces the plane while the superellipsoids were smoothed at 1e-7 m (the distance's
   curvature spike, controller.superellipsoid): 5 false 'unavoidable' in 42 labelled cases, 147 of
   149 switches in 72 MuJoCo runs. At the default 1e-3 m (controller.model.ModelOptions.
   support_smoothing) the labelled cases have none (bench/results/certificate_accuracy.md).
   Optional (`warm_start`; off by default): start it instead from the fresh Mode I plan (when there
   is one) with a small initial barrier (mu_init 1e-4). On the 11 minimum-violation calls of a
   MuJoCo run of wall-headon (seed 1, 3 s) the default start failed on 3 (in 2.5, 2.6 and 9.6 s:
   each of them a switch to Mode II); this one, on the 10 that had a fresh plan, on none (every one
   a zero minimum violation). Yet MuJoCo's closed loops end worse with it (11 of 18 hard runs
   succeed against 13 with the paper's Mode II hand-over, bench/results/switch_variants): our
   reading is that under plant-model mismatch "F is empty on the model" comes too late, and that
   the default's failures, which come when the vehicle is close and the problem turns hard, stand
   in for a robustness margin.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from enum import Enum

import numpy as np

from controller.mode1 import ModeIOCP, ModeISettings, OCPSolution, Solver
from controller.model import UVMSModel
from controller.rollouts import BrakingPolicy, rollout, simulate
from controller.transcription import FEASIBLE_VIOLATION, SolverStatus
from uvms.scene import Plane

MIN_VIOLATION_MAX_ITER = 300  # the minimum-violation problem's IPOPT iteration cap (FeasibilityTest's max_iter)


class Verdict(Enum):
    FEASIBLE = "feasible"
    INFEASIBLE = "infeasible"
    UNDECIDED = "not certified by the screens (the minimum-violation problem was not asked)"
    PENDING = "not certified by the screens; the minimum-violation problem runs in the background"


class Stop(Enum):
    """Where the minimum-violation IPOPT stops before its own convergence test (the module's doc)."""

    NONE = "run to its end"
    SLACK = "at the first iterate with slacks within the tolerance, its constraints met and an RK4 witness"
    WITNESS = "at the first iterate whose inputs, re-simulated by RK4, are a point of F"


class Method(Enum):
    BRAKING_ROLLOUT = "braking rollout"
    PREVIOUS_PLAN = "previous plan, shifted"
    MODE_I_PLAN = "Mode I's plan"
    GLOBALIZED_SQP = "Mode I's SQP with a line search"
    MINIMUM_VIOLATION = "minimum violation"
    SCREENS = "screens only"


@dataclass(frozen=True)
class Certificate:
    """The verdict on F and its evidence."""

    verdict: Verdict
    method: Method
    violation: float  # m: minimum total clearance violation (0 when a screen certified F; nan: UNDECIDED)
    rollout_clearance: float  # m: smallest clearance minus margin along the braking rollout
    solve_time: float  # s
    solution: OCPSolution | None  # the minimum-violation solution, or the line-search SQP's certified plan
    rollout: np.ndarray  # (N+1, ns) the braking rollout's states
    rollout_inputs: np.ndarray | None = None  # (N, nu) the braking rollout's inputs
    age: float = 0.0  # s: how much older the state the minimum violation judged is than this step's (background)


class FeasibilityTest:
    """Decide F != {} for Mode I's OCP (same model, planes and settings)."""

    def __init__(self, model: UVMSModel, planes: Sequence[Plane], settings: ModeISettings | None = None,
                 tolerance: float = 1e-3, search_iterations: int = 0, warm_start: bool = False,
                 retry: bool = False, max_iter: int = MIN_VIOLATION_MAX_ITER, stop: Stop = Stop.WITNESS,
                 plan_start: bool = True):
        """`search_iterations`: the line-search SQP screen's budget (0: no such screen; 20 is the
        tested value; it also needs settings.compiled). `warm_start`: the minimum-violation problem
        starts from the fresh Mode I plan when there is one (the module's docstring). `retry`: when
        IPOPT fails on the minimum-violation problem from the braking rollout, solve it again, with
        the same options, from the fresh Mode I plan when there is one (opt-in: on the three hardest
        MuJoCo families 63 of 72 against the default's 64, with 7 of 149 switches decided by an IPOPT
        failure against 53 of 143; bench/results/certificate_retry). `max_iter`: the minimum-violation
        problem's IPOPT iteration cap (at it, F counts as empty unless the iterate is feasible with a
        slack sum within the tolerance). Its solves take 0.4 to 3 s up to about 160 iterations, but
        9 s at 230 to 300 in a MuJoCo run (wall-oblique seed 11). With 100 the three hardest MuJoCo
        families and thrusters-dead end every run as with 300, in a third of the wall clock
        (bench/results/certificate_cap), but 5 of the 24 labelled approaches around F's threshold
        that F calls avoidable become 'unavoidable' (bench/results/certificate_accuracy_cap100.md),
        so 300 stays. `stop`: where IPOPT stops before its own test (Stop; the module's docstring).
        `plan_start`: the minimum-violation problem starts from the fresh Mode I plan when there is
        one, else from the braking rollout (False: always from the braking rollout)."""
        settings = settings or ModeISettings()
        self.model, self.settings, self.tolerance, self.retry = model, settings, tolerance, retry
        self.stop, self.plan_start = stop, plan_start
        self._witness: np.ndarray | None = None  # the states of the last witness (Stop.WITNESS)
        self._clearances: dict = {}  # min_clearance's mapped clearance functions, by number of nodes
        # Started cold from the rollout: a large initial barrier and no warm-start point work best
        # (with Mode I's warm-start options IPOPT hit 100 iterations on the unavoidable case). The
        # monotone barrier stays: the adaptive one reached a zero violation on 15 of 18 problems
        # recorded in MuJoCo closed loops where this one reached 10 (the rest hit the cap and so count
        # as F empty, the safe side), but the later switches it brought let an arm link hit the wall
        # in wall-headon without mismatch (the note on issue 4).
        cold = replace(settings, max_iter=max_iter, ipopt_options={
            "warm_start_init_point": "no", "mu_init": 0.1, **settings.ipopt_options})
        proof = {Stop.NONE: None, Stop.SLACK: self.proves_f, Stop.WITNESS: self.is_witness}[stop]
        self.problem = ModeIOCP(model, planes, cold, min_violation=True, stop=proof)
        self.warm = ModeIOCP(model, planes, replace(cold, ipopt_options={
            "warm_start_init_point": "no", "mu_init": 1e-4, **settings.ipopt_options}), min_violation=True,
            stop=proof) if warm_start else None
        self.braking = BrakingPolicy(model)
        self.search = ModeIOCP(model, planes, replace(settings, solver=Solver.SQP)) \
            if settings.compiled and search_iterations > 0 else None
        self.search_settings = replace(settings.sqp, max_iter=max(search_iterations, 1), line_search=True,
                                       real_time=True)

    def limit_inputs(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Replace the input bounds of every problem and rollout (e.g. known-failed thrusters: both 0)."""
        for ocp in (self.problem, self.search, self.warm):
            if ocp is not None:
                ocp.limit_inputs(lo, hi)
        self.braking.limit_thrust(lo, hi)

    def braking_rollout(self, h0: np.ndarray, current: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """States (N+1, ns) at the horizon's nodes and inputs (N, nu) under maximum braking with
        the joints held at their posture (controller.rollouts.BrakingPolicy), held over each
        interval and integrated by RK4 in 4 substeps."""
        s = self.settings
        h0 = np.asarray(h0, float)
        return rollout(self.model, self.braking, h0, h0[6:6 + self.model.n_joints], s.dt, s.horizon, current=current)

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

    def proves_f(self, sol: OCPSolution, p: np.ndarray) -> bool:
        """Stop.SLACK: the minimum-violation iterate `sol` (for parameters p = (h0, h_ref, current))
        as a proof that F is not empty: constraints within FEASIBLE_VIOLATION, slack sum within the
        tolerance, and `is_witness`."""
        return (sol.violation <= FEASIBLE_VIOLATION and float(np.sum(sol.slack)) <= self.tolerance
                and self.is_witness(sol, p))

    def is_witness(self, sol: OCPSolution, p: np.ndarray) -> bool:
        """Stop.WITNESS: whether the iterate's inputs, re-simulated from h0 by the model's RK4, pass
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

    def search_plan(self, h0: np.ndarray, h_ref: np.ndarray, start: tuple[np.ndarray, np.ndarray],
                    current: np.ndarray | None = None) -> OCPSolution | None:
        """The line-search SQP's plan from `start` (states (N+1, ns), inputs (N, nu)) when it is a
        point of F: it satisfies the OCP's constraints (violation below FEASIBLE_VIOLATION), or its
        inputs re-simulated from h0 pass `plan_is_feasible`; else None (also without the screen)."""
        if self.search is None:
            return None
        sol = self.search.solve(h0, h_ref, current, guess=self.search.guess_from_rollout(*start),
                                sqp=self.search_settings)
        if sol.status.usable and (sol.violation <= FEASIBLE_VIOLATION or
                                  self.resimulated_if_feasible(h0, sol.u, current) is not None):
            return sol
        return None

    def __call__(self, h0: np.ndarray, h_ref: np.ndarray, current: np.ndarray | None = None,
                 previous: OCPSolution | None = None, plan: tuple[np.ndarray, np.ndarray] | None = None,
                 fresh: Callable[[], tuple[np.ndarray, np.ndarray] | None] | None = None,
                 minimum_violation: bool = True, needed: Callable[[Certificate], bool] | None = None
                 ) -> Certificate:
        """The verdict for the measured state h0. `plan`: the previous Mode I plan shifted by one
        interval, as (states re-simulated from h0, inputs): the second screen. `fresh`: called
        when the screens before it fail, returns a new Mode I plan in the same form (or None): the
        third. With `minimum_violation=False` the screens alone decide: UNDECIDED when none of them
        finds a point of F (fast: no IPOPT). `needed`: called with that UNDECIDED certificate
        before the minimum-violation problem; when it returns False (the caller's decision does
        not depend on the answer) the problem is not solved and that certificate is returned."""
        t0 = time.perf_counter()
        hs, us = self.braking_rollout(h0, current)
        margin = self.min_clearance(hs) - self.settings.distance_margin

        def found(method: Method, sol: OCPSolution | None = None) -> Certificate:
            return Certificate(Verdict.FEASIBLE, method, 0.0, margin, time.perf_counter() - t0, sol, hs, us)

        if margin >= 0:
            return found(Method.BRAKING_ROLLOUT)
        if plan is not None and self.plan_is_feasible(*plan):
            return found(Method.PREVIOUS_PLAN)
        candidate = fresh() if fresh is not None else None
        if candidate is not None and self.plan_is_feasible(*candidate):
            return found(Method.MODE_I_PLAN)
        sol = self.search_plan(h0, h_ref, plan if plan is not None else (hs, us), current)
        if sol is not None:
            return found(Method.GLOBALIZED_SQP, sol)
        undecided = Certificate(Verdict.UNDECIDED, Method.SCREENS, np.nan, margin, time.perf_counter() - t0, None,
                                hs, us)
        if not minimum_violation or (needed is not None and not needed(undecided)):
            return undecided
        if self.warm is not None and candidate is not None:
            sol = self.warm.solve(h0, h_ref, current, guess=self.warm.guess_from_rollout(*candidate))
        else:
            start = candidate if self.plan_start and candidate is not None else (hs, us)
            sol = self.problem.solve(h0, h_ref, current, previous, guess=self.problem.guess_from_rollout(*start))
            if self.retry and not sol.status.usable and candidate is not None and start is not candidate:
                sol = self.problem.solve(h0, h_ref, current, previous,
                                         guess=self.problem.guess_from_rollout(*candidate))
        return self.judge(sol, margin, time.perf_counter() - t0, hs, us)

    def judge(self, sol: OCPSolution, rollout_clearance: float, seconds: float, hs: np.ndarray,
              us: np.ndarray) -> Certificate:
        """The verdict of a minimum-violation solution: F empty when its slack sum exceeds the
        tolerance, or when IPOPT could not use its solve (violation inf). hs, us: the braking rollout.
        A witness (Stop.WITNESS) is a point of F: violation 0, its plan the re-simulated states."""
        if sol.status is SolverStatus.STOPPED and self.stop is Stop.WITNESS:
            sol, violation = replace(sol, h=self._witness), 0.0
        else:
            violation = float(np.sum(sol.slack)) if sol.status.usable else np.inf
        verdict = Verdict.FEASIBLE if violation <= self.tolerance else Verdict.INFEASIBLE
        return Certificate(verdict, Method.MINIMUM_VIOLATION, violation, rollout_clearance, seconds, sol, hs, us)
