"""Mode II of the switching NMPC (paper Sec. IV-B): bring the end-effector into contact with the
obstacle at the end of the horizon, every body kept off every plane, with the timestep optimized.

Variables per stage: x_k = (h_k, dt_k), v_k = (u_k, a_k), with dt_k+1 = dt_k (the one timestep carried
as a state keeps the NLP stage-structured: controller.stage_nlp). Constraints: the midpoint dynamics
over dt (controller.transcription), dt_min <= dt <= dt_max, input and joint bounds, the clearances of
controller.transcription.clearances (the end-effector may touch the contact plane only) and, at the
last node, the tip on the contact plane (eq. EE_Wall_Dist_Constraint). Objective (eq. Obj2):
1/(d_0,N + eps) + w |V_ee,N| with the hull's distance d_0 and the end-effector's velocity at the last
node (|V_ee| smoothed over 0.1 m/s: below that speed the term is nearly quadratic), plus a
regularization of the inputs (1e-7 /N^2) and of the angular and joint rates (1e-2 s^2/rad^2), which
the paper's objective leaves free at most stages.

Not in the paper, the impact (`impact_fraction`): J_II also pays `impact_weight` times the tip's
approach speed at the last node beyond the speed at which controller.impact's law predicts a peak
of that fraction of the jaws' force limit (in the guess's last posture): an exact penalty, so the
bound holds whenever some plan meets it, and the solution's predicted peak says whether it did.

Not in the paper, for the hand-over to Mode III (with controller.switching's contact check):
intervals of 0.05 s (dt in [0.025, 0.05] s; the paper: 0.1 s), and `terminal_margin` (4 cm): at
contact every body the contact plane's clearances cover (the hull, every link but the last) is that
far off the plane, so the arm meets the wall end-on like a strut. Evidence: docs/decisions.md,
'0.05 s intervals, meeting the wall end-on'.

Algorithm 1's variable horizon: on entry N_p = ceil(t_c / dt_nom), t_c the time to contact of a
braking-and-deploying rollout (the paper's nominal N_p, with dt >= dt_min, forbids contact sooner
than N_p dt_min). Each N_p is a different NLP, built on first use and cached; the stage functions
and their compiled derivatives do not depend on N_p and are built once per contact plane (about
1.3 s), so a new N_p costs only its NLP's assembly (about 10 ms).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from controller import impact
from controller.codegen import NumpyCall
from controller.model import WATER, UVMSModel, water
from controller.rollouts import BrakingPolicy, JointHold, ReachPosture
from controller.stage_nlp import StageProblem, build_solver, stage_functions
from controller.transcription import (
    SolverStatus,
    clearances,
    contact_rows,
    ipopt_status,
    midpoint_residual,
    smooth_norm,
    smooth_relu,
    tip_gap,
)
from uvms.scene import Plane


@dataclass(frozen=True)
class ModeIISettings:
    """Mode II settings (s, m; weights make the cost's terms 1/m and s/m)."""

    horizon: int = 20  # N_p on entry
    dt_nominal: float = 0.05  # s (Algorithm 1's dt_nom; the paper: 0.1, see the module's docstring)
    dt_bounds: tuple[float, float] = (0.025, 0.05)  # s (dt_max = dt_nom: Algorithm 1 then shortens N_p every step)
    eps: float = 0.05  # m, J_II's epsilon
    ee_speed_weight: float = 2.0  # s/m, J_II's w
    # m/s: |V_ee| taken as sqrt(|V_ee|^2 + this^2). At 0.02 the term's curvature at a slow tip (w / 0.02 =
    # 100 s^2/m^2) left IPOPT at its cap in 618 of thrusters-dead's 2147 solves (experiments/mode2_speed_smoothing)
    ee_speed_smoothing: float = 0.1
    input_weight: float = 1e-7  # 1/N^2 regularization
    rate_weight: float = 1e-2  # s^2/rad^2, on the hull's angular and the joints' rates (no thrashing)
    distance_margin: float = 0.005  # m, bodies' clearance (the paper: >= 0)
    impact_fraction: float | None = 0.75  # of the jaws' tip_force_limit: the planned impact's peak (None: unbounded)
    impact_weight: float = 100.0  # s/m, J_II's exact penalty on the tip's approach speed beyond that peak's
    impact_smoothing: float = 0.01  # m/s, that penalty's relu
    terminal_margin: float | None = 0.04  # m, other bodies off the contact plane at contact (None: as above)
    # m: a clearance row already below its bound at h0 is held at its h0 clearance less this instead
    # (None: every row at its bound, so a state inside the margin makes every plan infeasible)
    hold_violated: float | None = None
    deploy_stiffness: float = 10.0  # N m/rad, the initial guess's arm PD
    deploy_damping: float = 1.5  # N m s/rad
    max_iter: int = 100  # IPOPT
    tol: float = 1e-6
    ipopt_options: dict = field(default_factory=dict)
    warm_start: bool = True  # from the previous solve's multipliers too, with a small initial barrier


@dataclass(frozen=True)
class ModeIISolution:
    status: SolverStatus
    h: np.ndarray  # (N+1, ns)
    u: np.ndarray  # (N, nu)
    dt: float  # s
    solve_time: float  # s
    iterations: int
    cost: float
    w: np.ndarray
    impact_force: float = float("nan")  # N, the planned contact's predicted peak (controller.impact)
    lam_g: np.ndarray | None = None  # constraint multipliers (None: no solve's)
    lam_x: np.ndarray | None = None  # bound multipliers


class ModeIIOCP:
    """Mode II's NLPs for one model, a set of planes and the contact plane's index."""

    def __init__(self, model: UVMSModel, planes: Sequence[Plane], contact: int,
                 settings: ModeIISettings = ModeIISettings()):
        self.model, self.planes, self.contact, self.settings = model, tuple(planes), contact, settings
        p, s = model.params, settings
        ns, nu, nv = model.n_states, model.n_inputs, model.n_speeds
        self.ns, self.nu, self.nv = ns, nu, nv
        plane = self.planes[contact]
        h, h1, u, a, dt, dt1 = (ca.SX.sym("h", ns), ca.SX.sym("h1", ns), ca.SX.sym("u", nu), ca.SX.sym("a", nv),
                                ca.SX.sym("dt"), ca.SX.sym("dt1"))
        P = ca.SX.sym("P", ns + 1 + WATER + 1)  # h0, dt0 (unused: dt_0 is free), water, allowed approach speed
        vc, v_allowed = P[ns + 1:ns + 1 + WATER], P[ns + 1 + WATER]
        self._clearance = ca.Function("clear2", [h], [clearances(model, h, self.planes, contact)])
        self.n_clear = self._clearance.size1_out(0)
        self._contact_rows = contact_rows(model, self.planes, contact)
        st = ca.vertcat(h, dt, u, a, h1, dt1)
        cons = ca.vertcat(midpoint_residual(model, h, u, a, h1, dt, vc), dt1 - dt, self._clearance(h1))
        rates = h1[nv + 3:]  # hull angular and joint rates
        cost = s.input_weight * ca.dot(u, u) + s.rate_weight * ca.dot(rates, rates)
        xN = ca.vertcat(h1, dt1)
        d0 = model.distances(h1, ca.DM(plane.normal), plane.offset)[0]
        v_ee = model.jacobian_ee(h1)[:3, :] @ h1[nv:]
        terminal_cost = 1 / (d0 + s.eps) + s.ee_speed_weight * smooth_norm(v_ee, s.ee_speed_smoothing)
        if s.impact_fraction is not None:
            approach = -ca.dot(ca.DM(plane.normal), v_ee)
            terminal_cost += s.impact_weight * smooth_relu(approach - v_allowed, s.impact_smoothing)
        self._stage = (ca.Function("cost2", [st, P], [cost]), ca.Function("cons2", [st, P], [cons]),
                       ca.Function("tcost2", [xN, P], [terminal_cost]),
                       ca.Function("tcons2", [xN, P], [tip_gap(model, h1, plane)]))
        self._name = f"mode2_{p.name}_{p.arm.name}_{plane.name}"
        # The adaptive barrier (probing oracle) converged on 23 of 26 Mode II problems recorded in MuJoCo
        # closed loops, the monotone one from mu_init = 0.1 on 16.
        self._ipopt = {"print_level": 0, "max_iter": s.max_iter, "tol": s.tol, "mu_strategy": "adaptive",
                       "mu_oracle": "probing", "sb": "yes", **s.ipopt_options}
        # From a previous plan, shifted, with its multipliers: a warm-started interior point, monotone from
        # mu 1e-3. On 100 recorded problems (bench/results/mode2_warm_start.md) 88 usable vs 77 cold,
        # iterations 15 vs 22 median, 349 vs 634 ms p95; from mu 1e-2, 69 usable.
        self._warm_ipopt = {**self._ipopt, "warm_start_init_point": "yes", "warm_start_bound_push": 1e-6,
                            "warm_start_mult_bound_push": 1e-6, "mu_init": 1e-3, "mu_strategy": "monotone",
                            **s.ipopt_options}
        self._solvers: dict[tuple[int, bool], ca.Function] = {}
        self._functions = stage_functions(self._problem(1), self._name)
        self._lo_u, self._hi_u = p.input_bounds()
        self._q_lo = np.array([lk.joint_range[0] for lk in p.arm.links])
        self._q_hi = np.array([lk.joint_range[1] for lk in p.arm.links])
        self.reach = ReachPosture(model, plane)
        self.deploy = BrakingPolicy(model, JointHold(s.deploy_stiffness, s.deploy_damping))
        self._gap_maps: dict[int, NumpyCall] = {}
        # _reach_contact's last (arguments, (posture, t_c)): deploy_guess after time_to_contact recomputes neither
        self._contact_time: tuple[tuple, tuple[np.ndarray, float | None]] | None = None

    def protected_clearance(self, h: np.ndarray) -> float:
        """Smallest clearance [m] of what Mode II keeps off the planes (every body and the tip, except
        the tip and the last link against the contact plane) at state h."""
        return float(np.asarray(self._clearance(h)).min())

    def limit_inputs(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Replace the input bounds (e.g. known-failed thrusters: both 0)."""
        self._lo_u, self._hi_u = np.asarray(lo, float), np.asarray(hi, float)
        self.deploy.limit_thrust(lo, hi)

    def _problem(self, N: int) -> StageProblem:
        cost, cons, tcost, tcons = self._stage
        return StageProblem(nx=self.ns + 1, nv=self.nu + self.nv, horizon=N, np=self.ns + 2 + WATER, cost=cost,
                            constraints=cons, terminal_cost=tcost, terminal_constraints=tcons, n_fixed=self.ns)

    def solver(self, N: int, warm: bool = False) -> ca.Function:
        """The NLP for horizon N, cold or warm-started (assembled on first use from the shared
        compiled stage functions, then cached)."""
        if (N, warm) not in self._solvers:
            self._solvers[N, warm] = build_solver(self._problem(N), self._name,
                                                  self._warm_ipopt if warm else self._ipopt, self._functions)
        return self._solvers[N, warm]

    def shifted_duals(self, sol: ModeIISolution, N_next: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The multipliers of `sol` for the next horizon, resampled as `shifted_guess` resamples its
        inputs (each new interval takes those of the old interval its midpoint falls in); None
        without them."""
        if sol.lam_g is None or sol.lam_x is None:
            return None
        N, ns, nz = len(sol.u), self.ns, self.ns + 1 + self.nu + self.nv
        nc = (len(sol.lam_g) - ns - 1) // N
        idx = _resampled(sol, N_next)
        stages_g, stages_x = sol.lam_g[ns:ns + N * nc].reshape(N, nc), sol.lam_x[:N * nz].reshape(N, nz)
        return (np.concatenate([sol.lam_g[:ns], stages_g[idx].ravel(), sol.lam_g[-1:]]),
                np.concatenate([stages_x[idx].ravel(), sol.lam_x[N * nz:]]))

    # ------------------------------------------------------------------------------------------
    def time_to_contact(self, h0: np.ndarray, N_max: int, current: np.ndarray | None = None) -> float | None:
        """t_c [s]: when the deploy policy (`deploy_guess`), acting every 0.01 s from h0, first puts
        the tip on the contact plane (to 0.01 s); None if not within N_max intervals of dt_max. The
        last answer is kept, so that `deploy_guess` on the same arguments does not roll out again."""
        return self._reach_contact(h0, N_max, current)[1]

    def _reach_contact(self, h0: np.ndarray, N_max: int, current: np.ndarray | None
                       ) -> tuple[np.ndarray, float | None]:
        """The deploy policy's posture (ReachPosture: three small IPOPT solves) and `time_to_contact`."""
        h0 = np.asarray(h0, float)
        key = (h0.tobytes(), N_max, None if current is None else np.asarray(current, float).tobytes())
        if self._contact_time is None or self._contact_time[0] != key:
            fine, posture = 0.01, self.reach(h0)
            hs, _ = self.deploy.rollout(h0, posture, fine, self._fine_steps(N_max), 1, current, every_substep=True)
            hit = np.flatnonzero(self._gaps(N_max)(hs[1:])[0] <= 0.0)  # column-major (ns, n): the rows of hs
            self._contact_time = (key, (posture, (hit[0] + 1) * fine if hit.size else None))
        return self._contact_time[1]

    def deploy_guess(self, h0: np.ndarray, N_max: int, current: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """The entry guess: brake at full thrust while the arm swings to the posture that reaches
        furthest towards the contact plane (computed torque + PD). The rollout's time to contact
        t_c (`time_to_contact`) sets the horizon as Algorithm 1 does for later steps, N_p =
        ceil(t_c / dt_nom) (at most N_max; N_max and dt_max if the tip never reaches the plane), and
        dt = t_c / N_p within dt_bounds (so N_p dt exceeds t_c when t_c / N_p < dt_min)."""
        s = self.settings
        fine, h0 = 0.01, np.asarray(h0, float)
        posture, t_contact = self._reach_contact(h0, N_max, current)
        N = min(N_max, next_horizon(2, t_contact, s.dt_nominal)) if t_contact else N_max
        dt = float(np.clip(t_contact / N if t_contact else s.dt_bounds[1], *s.dt_bounds))
        # The policy is stiff (computed torque + PD): held over a whole interval it goes unstable and
        # swings the arm through the wall, so it acts every substep and each interval's input is its mean.
        hs, us = self.deploy.rollout(h0, posture, dt, N_max, math.ceil(dt / fine), current, every_substep=True)
        return hs[:N + 1], us[:N], dt

    def _fine_steps(self, N_max: int) -> int:
        """The 0.01 s steps of `deploy_guess`'s search for the time to contact over N_max intervals."""
        return math.ceil(N_max * self.settings.dt_bounds[1] / 0.01)

    def _gaps(self, N_max: int) -> NumpyCall:
        """The tip's gap to the contact plane [m] at each state of `deploy_guess`'s fine rollout."""
        n = self._fine_steps(N_max)
        if n not in self._gap_maps:
            h = ca.SX.sym("h", self.ns)
            gap = ca.Function("gap2", [h], [tip_gap(self.model, h, self.planes[self.contact])])
            self._gap_maps[n] = NumpyCall(gap.map(n))
        return self._gap_maps[n]

    def prepare_guesses(self, N_max: int) -> None:
        """Compile `deploy_guess`'s rollouts for N_max (every substep count its dt_bounds allow) now,
        not at the first switch (about 10 s each on a cache miss, then loaded from disk)."""
        s, fine = self.settings, 0.01
        self.deploy.compiled_rollout(self._fine_steps(N_max), 1, True)
        for m in range(max(1, math.floor(s.dt_bounds[0] / fine)), math.ceil(s.dt_bounds[1] / fine) + 1):
            self.deploy.compiled_rollout(N_max, m, True)
        self._gaps(N_max)

    def pack(self, hs: np.ndarray, us: np.ndarray, dt: float) -> np.ndarray:
        N, nv = len(us), self.nv
        blocks = [np.concatenate([hs[k], [dt], us[k], (hs[k + 1, -nv:] - hs[k, -nv:]) / dt]) for k in range(N)]
        return np.concatenate([*blocks, hs[N], [dt]])

    def solve(self, h0: np.ndarray, guess: tuple[np.ndarray, np.ndarray, float],
              current: np.ndarray | None = None, duals: tuple[np.ndarray, np.ndarray] | None = None
              ) -> ModeIISolution:
        """Solve from h0 with a primal guess (states (N+1, ns), inputs (N, nu), dt); with `duals`
        (lam_g, lam_x: `shifted_duals`) and `warm_start`, by the warm-started solver."""
        hs, us, dt0 = guess
        N, ns, nu, nv = len(us), self.ns, self.nu, self.nv
        nz = ns + 1 + nu + nv
        warm = duals is not None and self.settings.warm_start
        solver = self.solver(N, warm)
        lbw, ubw = np.full(N * nz + ns + 1, -np.inf), np.full(N * nz + ns + 1, np.inf)
        for k in range(N + 1):
            i = k * nz
            lbw[i + ns], ubw[i + ns] = self.settings.dt_bounds
            if k > 0:
                lbw[i + 6:i + 6 + self.model.n_joints] = self._q_lo
                ubw[i + 6:i + 6 + self.model.n_joints] = self._q_hi
            if k < N:
                lbw[i + ns + 1:i + ns + 1 + nu], ubw[i + ns + 1:i + ns + 1 + nu] = self._lo_u, self._hi_u
        nc = ns + nv + 1 + self.n_clear
        lbg, ubg = np.zeros(ns + N * nc + 1), np.zeros(ns + N * nc + 1)
        s = self.settings
        lb = np.full(self.n_clear, s.distance_margin)
        lb_terminal = lb.copy()
        if s.terminal_margin is not None:  # the last node: every protected body off the contact plane
            lb_terminal[self._contact_rows] = s.terminal_margin
        if s.hold_violated is not None:  # no closer than at h0 (less the allowance)
            c0 = np.asarray(self._clearance(h0)).ravel() - s.hold_violated
            lb, lb_terminal = np.minimum(lb, c0), np.minimum(lb_terminal, c0)
        for k in range(N):
            i = ns + k * nc + ns + nv + 1
            lbg[i:i + self.n_clear], ubg[i:i + self.n_clear] = lb_terminal if k == N - 1 else lb, np.inf
        w0 = np.clip(self.pack(hs, us, dt0), lbw, ubw)
        P = np.concatenate([h0, [dt0], water(current),
                            [min(self.allowed_speed(hs[-1]), 1e3)]])  # (a finite parameter)
        args = {"x0": w0, "p": P, "lbx": lbw, "ubx": ubw, "lbg": lbg, "ubg": ubg}
        if warm:
            args.update(lam_g0=duals[0], lam_x0=duals[1])
        t0 = time.perf_counter()
        r = solver(**args)
        elapsed = time.perf_counter() - t0
        st = solver.stats()
        w = np.asarray(r["x"]).ravel()
        h_plan = np.array([w[k * nz:k * nz + ns] for k in range(N + 1)])
        return ModeIISolution(status=ipopt_status(st), h=h_plan,
                              u=np.array([w[k * nz + ns + 1:k * nz + ns + 1 + nu] for k in range(N)]),
                              dt=float(w[ns]), solve_time=elapsed, iterations=int(st["iter_count"]),
                              cost=float(r["f"]), w=w, impact_force=self.impact_force(h_plan[-1]),
                              lam_g=np.asarray(r["lam_g"]).ravel(), lam_x=np.asarray(r["lam_x"]).ravel())

    def allowed_speed(self, h: np.ndarray) -> float:
        """The tip's approach speed [m/s] at which it meets the contact plane, in h's posture, with a peak
        of `impact_fraction` of the jaws' limit (controller.impact; inf without the bound)."""
        if self.settings.impact_fraction is None:
            return np.inf
        force = self.settings.impact_fraction * self.model.params.arm.tip_force_limit
        return force / impact.stiffness(self.model, h, self.planes[self.contact])

    def impact_force(self, h: np.ndarray) -> float:
        """The predicted peak normal force [N] of the tip meeting the contact plane from state h."""
        return impact.peak_force(self.model, h, self.planes[self.contact])


def next_horizon(N: int, dt: float, dt_nominal: float) -> int:
    """Algorithm 1: N_p(k+1) = ceil(t_exp / dt_nom) with t_exp = (N_p(k) - 1) dt* (at least 1)."""
    return max(1, math.ceil((N - 1) * dt / dt_nominal - 1e-9))


def shifted_guess(sol: ModeIISolution, N_next: int) -> tuple[np.ndarray, float]:
    """Inputs for the next horizon: the plan after its first interval, resampled (zero-order hold)
    onto N_next intervals that cover the same remaining time."""
    N = len(sol.u)
    dt = (N - 1) * sol.dt / N_next if N > 1 else sol.dt
    return sol.u[_resampled(sol, N_next)], dt


def _resampled(sol: ModeIISolution, N_next: int) -> np.ndarray:
    """For each of N_next intervals covering the plan's time after its first interval, the index of
    the plan's interval its midpoint falls in."""
    N = len(sol.u)
    dt = (N - 1) * sol.dt / N_next if N > 1 else sol.dt
    times = (np.arange(N_next) + 0.5) * dt
    return np.minimum(1 + (times // sol.dt).astype(int), N - 1)
