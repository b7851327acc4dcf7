"""Mode I of the switching NMPC (paper Sec. IV-A): track the task, keep every body off every plane.

Transcription (paper eq. OCP): multiple shooting over N intervals of dt with variables ordered
[h_0, u_0, a_0, h_1, u_1, a_1, ..., h_N] (stage-wise, as structure-exploiting solvers want). The
dynamics constraints (eq. DynConstraints) are written by the implicit midpoint rule in inverse-
dynamics form: with h_m = (h_k + h_k+1)/2, eta_k+1 = eta_k + dt eta_dot(h_m), nu_k+1 = nu_k + dt a_k
and M(q_m) a_k = Q(h_m, u_k). The accelerations a_k are decision variables, so the NLP never
contains M^-1: its derivatives are ~10x cheaper than those of an explicit RK4 step of the same
model (bench/results/ocp_formulations.md). The rule is second order and A-stable; predictions are
recomputed with the model's RK4 after each solve (paper: Final Algorithm).

Objective (eq. Obj1): sum_i e_i^T W_s e_i + u_i^T W_u u_i, e_i = h_i - h_ref. Constraints: input
bounds, joint limits, and for every body j and plane (n, D): d_j(h_i) >= margin (eq.
DistConstraints), plus the end-effector tip n.x_ee + D >= tip radius + margin.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import Enum

import casadi as ca
import numpy as np

from controller.iterate_stop import IterateStop
from controller.model import WATER, UVMSModel, water
from controller.sqp import SQPSettings, StageSQP
from controller.stage_nlp import StageProblem, build_solver
from controller.transcription import SolverStatus, clearances, ipopt_status, midpoint_residual
from uvms.scene import Plane

PITCH = 4  # the pitch angle's index in the state h = (x, y, z, roll, pitch, yaw, q, nu, qdot)


def _default_state_weights(n_joints: int) -> tuple[float, ...]:
    """Position 10, attitude 5 (roll, pitch) and 5 (yaw), joints 1; velocities 1, joint rates 0.1."""
    return (10.0,) * 3 + (5.0,) * 3 + (1.0,) * n_joints + (1.0,) * 6 + (0.1,) * n_joints


class Solver(Enum):
    """How Mode I's NLP is solved. SQP (default): Gauss-Newton SQP with HPIPM's structure-exploiting
    QP on the compiled stage blocks (controller.sqp); by default one iteration per control period,
    the real-time iteration (its budget: `sqp.max_iter`). IPOPT: interior point to convergence,
    exact Hessian, the same compiled blocks (or one SX NLP with compiled=False); the feasibility
    certificate's minimum-violation problem always uses it."""

    IPOPT = "ipopt"
    SQP = "sqp"


@dataclass(frozen=True)
class ModeISettings:
    """Mode I OCP settings (units: s, m, and the weights' units make the cost dimensionless)."""

    horizon: int = 20
    dt: float = 0.1  # s
    state_weights: tuple[float, ...] | None = None  # None: _default_state_weights
    input_weight: float = 1e-3  # 1/N^2 and 1/(N m)^2
    distance_margin: float = 0.02  # m
    # rad: |pitch| at nodes 1..N. The ZYX Euler rates are singular at +-pi/2 (controller.kinematics);
    # without a bound the certificate's IPOPT wandered through it (iterations of 100 ms, its Hessian
    # regularized by up to 1e13) and ended at its cap on 38 of 210 recorded MuJoCo problems that the
    # bound lets it solve (experiment min_violation_stop.md, experiments/README.md). None: no bound.
    pitch_limit: float | None = 1.2
    max_iter: int = 100  # IPOPT
    tol: float = 1e-6  # IPOPT
    compiled: bool = True  # per-stage derivatives compiled to C (controller.stage_nlp); False: one SX NLP
    ipopt_options: dict = field(default_factory=dict)
    solver: Solver = Solver.SQP
    sqp: SQPSettings = field(default_factory=SQPSettings)

    def __post_init__(self) -> None:
        if self.horizon < 1 or self.dt <= 0:
            raise ValueError(f"horizon {self.horizon}, dt {self.dt} s: allowed: horizon >= 1, dt > 0")
        if self.solver is Solver.SQP and not self.compiled:
            raise ValueError("solver SQP needs compiled=True (it runs on the compiled stage derivatives)")


@dataclass(frozen=True)
class OCPSolution:
    """A solved (or failed) OCP: trajectories over the horizon and solver figures."""

    status: SolverStatus
    h: np.ndarray  # (N+1, n_states)
    u: np.ndarray  # (N, n_inputs)
    a: np.ndarray  # (N, n_speeds) accelerations
    slack: np.ndarray  # (N, n_clear) clearance slacks [m] (empty unless min_violation)
    solve_time: float  # s, wall clock
    iterations: int
    cost: float
    w: np.ndarray  # raw primal vector
    lam_g: np.ndarray  # constraint multipliers (warm start)
    lam_x: np.ndarray  # bound multipliers (warm start)
    violation: float = float("nan")  # largest constraint violation of the returned iterate (m, N, N m)


class ModeIOCP:
    """The Mode I NLP, built once for a model, a set of planes and settings."""

    def __init__(self, model: UVMSModel, planes: Sequence[Plane], settings: ModeISettings = ModeISettings(),
                 min_violation: bool = False, stop: Callable[[OCPSolution, np.ndarray], bool] | None = None):
        """`min_violation=True` builds the feasibility problem instead: every clearance constraint
        gets an L1 slack sigma >= 0 and the cost is sum(sigma) [m] (plus 1e-6 of the tracking cost
        as regularization); its optimum is 0 exactly when Mode I's feasible set is non-empty.
        `stop` (IPOPT only): stop at the first iterate for which stop(its solution, the parameters
        (h0, h_ref, current)) holds (the solution's `violation`: the iterate's largest constraint
        violation); it is returned with status STOPPED (controller.iterate_stop)."""
        if stop is not None and settings.solver is Solver.SQP and not min_violation:
            raise ValueError("stop needs IPOPT; allowed: stop=None with solver SQP")
        self.model, self.planes, self.settings, self.min_violation = model, tuple(planes), settings, min_violation
        p = model.params
        ns, nu, nv, n = model.n_states, model.n_inputs, model.n_speeds, model.n_joints
        self.ns, self.nu, self.nv, N, dt = ns, nu, nv, settings.horizon, settings.dt
        weights = settings.state_weights or _default_state_weights(n)
        if len(weights) != ns:
            raise ValueError(f"state_weights has {len(weights)} entries; allowed: {ns}")
        # stage functions (SX; inlined into one SX NLP)
        h, h1, u, a = ca.SX.sym("h", ns), ca.SX.sym("h1", ns), ca.SX.sym("u", nu), ca.SX.sym("a", nv)
        vc = ca.SX.sym("vc", WATER)
        self._dynamics = ca.Function("dyn", [h, u, a, h1, vc], [midpoint_residual(model, h, u, a, h1, dt, vc)])
        self._clearance = ca.Function("clear", [h], [clearances(model, h, self.planes)])
        self.n_clear = self._clearance.size1_out(0)
        self.n_slack = self.n_clear if min_violation else 0
        self._nz = ns + nu + nv + self.n_slack
        # the NLP: stage k sees s_k = (h_k, u_k, a_k, sigma_k, h_k+1) and p = (h0, h_ref, water)
        st, P = ca.SX.sym("s", self._nz + ns), ca.SX.sym("P", 2 * ns + WATER)
        hk, uk, ak = st[:ns], st[ns:ns + nu], st[ns + nu:ns + nu + nv]
        sk, hk1 = st[ns + nu + nv:self._nz], st[self._nz:]
        e = hk1 - P[ns:2 * ns]
        tracking = ca.dot(ca.DM(weights) * e, e) + settings.input_weight * ca.dot(uk, uk)
        stage_cost = ca.Function("cost", [st, P], [ca.sum1(sk) + 1e-6 * tracking if min_violation else tracking])
        stage_constraints = ca.Function("cons", [st, P], [ca.vertcat(self._dynamics(hk, uk, ak, hk1, P[2 * ns:]),
                                                                      self._clearance(hk1) + sk if min_violation
                                                                      else self._clearance(hk1))])
        # Warm start; the adaptive barrier (probing oracle) for Mode I itself: with the monotone one IPOPT
        # stalled at its cap on some steps of the avoidable approach (tests/test_mode1.py) once the tip
        # became a 50 mm sphere. The minimum-violation problem keeps the monotone barrier (controller.
        # feasibility says why).
        barrier = {} if min_violation else {"mu_strategy": "adaptive", "mu_oracle": "probing"}
        ipopt = {"print_level": 0, "max_iter": settings.max_iter, "tol": settings.tol,
                 "warm_start_init_point": "yes", "warm_start_bound_push": 1e-6, "warm_start_mult_bound_push": 1e-6,
                 "mu_init": 1e-3, "sb": "yes", **barrier, **settings.ipopt_options}
        nw = N * self._nz + ns
        ng = ns + N * (ns + nv + self.n_clear)
        self._P = np.zeros(2 * ns + WATER)  # the parameters of the running solve (for the stop's check)
        self.stop = None
        if stop is not None:
            def accept(w: np.ndarray, g: np.ndarray) -> bool:
                return stop(self._solution(w, SolverStatus.STOPPED, np.nan, -1, np.nan, np.zeros(0), np.zeros(0),
                                           self._violation(g)), self._P)

            self.stop = IterateStop(nw, ng, accept)
        callback = {"iteration_callback": self.stop} if self.stop is not None else {}
        if settings.compiled:
            problem = StageProblem(nx=ns, nv=self._nz - ns, horizon=N, np=2 * ns + WATER, cost=stage_cost,
                                   constraints=stage_constraints)
            name = f"{'minviol' if min_violation else 'mode1'}_{p.name}_{p.arm.name}"
            if settings.solver is Solver.SQP and not min_violation:  # (the slacks' problem: IPOPT)
                self.solver, self.sqp = None, StageSQP(problem, name, n_alg=nv, settings=settings.sqp)
            else:
                self.solver, self.sqp = build_solver(problem, name, ipopt, options=callback), None
        else:
            self.sqp = None
            w, Pn = ca.SX.sym("w", nw), ca.SX.sym("P", 2 * ns + WATER)
            stages = [w[k * self._nz:(k + 1) * self._nz + ns] for k in range(N)]
            J = sum(stage_cost(sk, Pn) for sk in stages)
            g = ca.vertcat(w[:ns] - Pn[:ns], *[stage_constraints(sk, Pn) for sk in stages])
            self.solver = ca.nlpsol("mode1", "ipopt", {"x": w, "p": Pn, "f": J, "g": g},
                                    {"print_time": False, "ipopt": ipopt, **callback})
        # bounds
        lo, hi = p.input_bounds()
        self.lbw, self.ubw = np.full(nw, -np.inf), np.full(nw, np.inf)
        q_lo = np.array([lk.joint_range[0] for lk in p.arm.links])
        q_hi = np.array([lk.joint_range[1] for lk in p.arm.links])
        for k in range(N + 1):
            i = k * self._nz
            if k > 0:
                self.lbw[i + 6:i + 6 + n], self.ubw[i + 6:i + 6 + n] = q_lo, q_hi
                if settings.pitch_limit is not None:
                    self.lbw[i + PITCH], self.ubw[i + PITCH] = -settings.pitch_limit, settings.pitch_limit
            if k < N:
                self.lbw[i + ns:i + ns + nu], self.ubw[i + ns:i + ns + nu] = lo, hi
                self.lbw[i + ns + nu + nv:i + self._nz] = 0.0  # slacks
        self.lbg, self.ubg = np.zeros(ng), np.zeros(ng)
        idx = ns
        for _ in range(N):
            idx += ns + nv
            self.lbg[idx:idx + self.n_clear] = settings.distance_margin
            self.ubg[idx:idx + self.n_clear] = np.inf
            idx += self.n_clear

    def _violation(self, g: np.ndarray) -> float:
        """Largest violation of the constraint bounds by constraint values g."""
        return float(max(np.max(self.lbg - g), np.max(g - self.ubg), 0.0))

    def limit_inputs(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Replace the input bounds (e.g. known-failed thrusters: both 0)."""
        nu, ns = self.nu, self.ns
        for k in range(self.settings.horizon):
            i = k * self._nz + ns
            self.lbw[i:i + nu], self.ubw[i:i + nu] = lo, hi

    def plan_within_bounds(self, hs: np.ndarray, us: np.ndarray) -> bool:
        """Whether inputs (N, nu) and the pitch and joint angles of states hs[1:] lie within this
        problem's current bounds (failed thrusters included)."""
        ns, nu, nz, n = self.ns, self.nu, self._nz, self.model.n_joints
        lo, hi = self.lbw[ns:ns + nu], self.ubw[ns:ns + nu]
        x_lo, x_hi = self.lbw[nz + PITCH:nz + 6 + n], self.ubw[nz + PITCH:nz + 6 + n]  # pitch, yaw, joints
        return (len(us) == self.settings.horizon and bool(np.all(us >= lo - 1e-9) and np.all(us <= hi + 1e-9))
                and bool(np.all(hs[1:, PITCH:6 + n] >= x_lo) and np.all(hs[1:, PITCH:6 + n] <= x_hi)))

    # ------------------------------------------------------------------------------------------
    def guess_from_rollout(self, h: np.ndarray, u: np.ndarray) -> np.ndarray:
        """A primal start from a state trajectory h (N+1, ns) under inputs u (N, nu): accelerations
        by the midpoint rule's (nu_k+1 - nu_k) / dt, slacks just large enough."""
        ns, nv, dt = self.ns, self.nv, self.settings.dt
        blocks = []
        for k in range(self.settings.horizon):
            a = (h[k + 1, ns - nv:] - h[k, ns - nv:]) / dt
            sig = np.maximum(0.0, self.settings.distance_margin - np.asarray(self._clearance(h[k + 1])).ravel()) \
                if self.n_slack else np.zeros(0)
            blocks.append(np.concatenate([h[k], u[k], a, sig]))
        return np.concatenate([*blocks, h[-1]])

    def initial_guess(self, h0: np.ndarray, previous: OCPSolution | None = None) -> tuple[np.ndarray, ...]:
        """Primal and dual start: the previous solution shifted by one stage, or h0 held."""
        N, ns = self.settings.horizon, self.ns
        if previous is None:
            w = np.concatenate([np.concatenate([h0, np.zeros(self._nz - ns)])] * N + [h0])
            return w, None, None
        w = self._shift_primal(previous.w)
        w[:ns] = h0
        return w, self._shift(previous.lam_g), self._shift_primal(previous.lam_x)

    def _shift_primal(self, v: np.ndarray) -> np.ndarray:
        """Drop stage 0; repeat the last stage's (u, a) and the final state."""
        N, nz, ns = self.settings.horizon, self._nz, self.ns
        return np.concatenate([v[nz:], v[(N - 1) * nz + ns:N * nz], v[N * nz:]])

    def _shift(self, lam_g: np.ndarray) -> np.ndarray:
        ns, block = self.ns, self.ns + self.nv + self.n_clear
        stages = lam_g[ns:].reshape(self.settings.horizon, block)
        return np.concatenate([lam_g[:ns], stages[1:].ravel(), stages[-1]])

    def solve(self, h0: np.ndarray, h_ref: np.ndarray, current: np.ndarray | None = None,
              previous: OCPSolution | None = None, guess: np.ndarray | None = None,
              sqp: SQPSettings | None = None, stop: Callable[[np.ndarray], bool] | None = None) -> OCPSolution:
        """Solve from state h0 towards h_ref. Primal start: `guess` (e.g. `guess_from_rollout`) when
        given, else `previous` shifted by one stage, else h0 held; dual start: `previous` shifted.
        `sqp` replaces the SQP's iteration settings for this solve, and `stop(u)`, given the inputs
        (N, nu) after each SQP iteration, ends it as STOPPED when True (Solver.SQP only)."""
        w0, lam_g, lam_x = self.initial_guess(np.asarray(h0, float), previous)
        if guess is not None:
            w0 = guess
        P = np.concatenate([h0, h_ref, water(current)])
        if self.sqp is not None:
            inputs = None if stop is None else (lambda w: stop(self._inputs(w)))
            res = self.sqp.solve(w0, P, self.lbw, self.ubw, self.lbg[self.ns:], self.ubg[self.ns:], sqp, inputs)
            return self._solution(res.w, res.status, res.solve_time, res.iterations, res.cost,
                                  np.zeros(len(self.lbg)), np.zeros(len(w0)), res.violation)
        args = {"x0": w0, "p": P, "lbx": self.lbw, "ubx": self.ubw, "lbg": self.lbg, "ubg": self.ubg}
        if lam_g is not None:
            args.update(lam_g0=lam_g, lam_x0=lam_x)
        self._P = P
        if self.stop is not None:
            self.stop.fired = False
        t0 = time.perf_counter()
        r = self.solver(**args)
        elapsed = time.perf_counter() - t0
        st = self.solver.stats()
        inf_pr = st.get("iterations", {}).get("inf_pr", [np.nan])
        status, violation = ipopt_status(st), float(inf_pr[-1]) if inf_pr else np.nan
        if self.stop is not None and self.stop.fired:
            status, violation = SolverStatus.STOPPED, self._violation(np.asarray(r["g"]).ravel())
        return self._solution(np.asarray(r["x"]).ravel(), status, elapsed, int(st["iter_count"]),
                              float(r["f"]), np.asarray(r["lam_g"]).ravel(), np.asarray(r["lam_x"]).ravel(), violation)

    def _inputs(self, w: np.ndarray) -> np.ndarray:
        """The inputs (N, nu) in a primal vector."""
        N, nz, ns, nu = self.settings.horizon, self._nz, self.ns, self.nu
        return np.array([w[k * nz + ns:k * nz + ns + nu] for k in range(N)])

    def _solution(self, w: np.ndarray, status: SolverStatus, elapsed: float, iterations: int, cost: float,
                  lam_g: np.ndarray, lam_x: np.ndarray, violation: float) -> OCPSolution:
        N, nz, ns, nu = self.settings.horizon, self._nz, self.ns, self.nu
        return OCPSolution(
            status=status,
            h=np.array([w[k * nz:k * nz + ns] for k in range(N + 1)]),
            u=self._inputs(w),
            a=np.array([w[k * nz + ns + nu:k * nz + ns + nu + self.nv] for k in range(N)]),
            slack=np.array([w[k * nz + ns + nu + self.nv:(k + 1) * nz] for k in range(N)]),
            solve_time=elapsed, iterations=iterations, cost=cost, w=w, lam_g=lam_g, lam_x=lam_x, violation=violation)
