"""Mode III of the switching NMPC (paper Sec. IV-C): the end-effector stays on the obstacle and the
manipulator's contact force pushes the hull away.

Variables per stage: x_k = h_k, v_k = (u_k, a_k, F_k) with F_k = (F_n, F_t1, F_t2) the contact force
on the end-effector in the obstacle frame (x along the plane's normal, controller.transcription.
obstacle_frame). The tip is a sphere, so the contact transmits no torque. Constraints: the midpoint
dynamics with F_k (controller.transcription), the tip on the plane at every node (eq.
EE_Wall_Dist_Constraint), F_n >= 0, the friction law, and the clearances of every body except the
end-effector's link against the contact plane. Friction (eq. Friction_Constraint, smooth form):
F_t = -mu F_n v_t / sqrt(|v_t|^2 + delta^2), v_t the tip's tangential velocity at the interval's
midpoint: the paper's two rows to within |v_t| / sqrt(|v_t|^2 + delta^2), and viscous below delta
(1 cm/s), so the controller never counts on sticking.

Objective (eq. Obj3): sum_i w_i relu(-d0_dot_i), w_i = 1 + (N - i)/(N - 1): the paper's J_III read
as the hull's approach speed [m/s], relu smoothed at 1 cm/s (controller.transcription.smooth_relu;
at 1 mm/s its curvature made the Hessian indefinite). Not in the paper: `clearance_weight` [1/s]
times the hull's shortfall from `hull_clearance` (5 cm) to the contact plane, relu-smoothed at 1 cm,
and, while every thruster is dead, `spin_weight` [s^2/rad^2] times the hull's squared angular rates
and `strut_weight` [1/m^2] times the squared moment arm of the wall's push about the hull's centre
of mass (all four parameters of the compiled problem). Regularization: 1e-5 |u|^2, 1e-6 |F|^2 and
1e-3 of the squared angular and joint rates (without it the inputs and the posture are free once the hull
separates, and IPOPT creeps along that valley). IPOPT stops at its acceptable level (dual
infeasibility 1e-2, constraints 1e-5) after 3 such iterations. The horizon is 5 intervals (0.5 s)
while every thruster is dead and 3 (0.3 s) while some thruster lives, not the paper's 20.
Evidence: docs/decisions.md, 'Over 0.5 s', 'Over 0.3 s while a thruster lives', 'J_III's
hull-clearance term' and 'J_III's strut term'.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from controller.model import WATER, UVMSModel, water
from controller.stage_nlp import StageProblem, build_solver, stage_functions
from controller.transcription import (
    SolverStatus,
    clearances,
    ipopt_status,
    midpoint_residual,
    obstacle_frame,
    smooth_relu,
    tip_gap,
)
from uvms.scene import Plane

IK_NEWTON_ITERATIONS = 8  # onto_plane's Newton iterations before it asks IPOPT


@dataclass(frozen=True)
class ModeIIISettings:
    horizon: int = 5  # the paper uses N_p = 20 for all modes; 5 (0.5 s): see the module docstring
    # intervals while some thruster lives (not known-failed); None: `horizon`. The switching NMPC
    # picks its Mode III problem by this rule (SwitchingNMPC.ocp3). Over 0.3 s Mode III answers
    # within 50 ms far more often (strict real time: 57/72 vs 43/72, Mode III late 11 % vs 43 %),
    # but with every thruster dead it cannot hold the hull off (experiments/realtime_mode3_thrust,
    # experiments/realtime_mode3_short)
    thrust_horizon: int | None = 3
    dt: float = 0.1  # s
    friction: float = 0.5  # the controller's friction coefficient mu [-]
    friction_smoothing: float = 0.01  # m/s, delta
    approach_smoothing: float = 0.01  # m/s, the relu of J_III (curvature 1/this at d0_dot = 0)
    distance_margin: float = 0.005  # m
    # m: with the tip further than this off the plane at h0, and live thrusters that can push the
    # hull away from the plane, the first interval plans no contact force: the wall cannot push
    # before the tip touches it, and the torques meant to hold the arm against a planned force
    # throw the tip onto the wall (experiments/mode3_first_interval). Without such thrust the arm
    # is the hull's only brake and the force stays planned. None: the paper's (force from the first
    # interval on)
    force_free_gap: float | None = 0.003
    input_weight: float = 1e-5  # 1/N^2
    force_weight: float = 1e-6  # 1/N^2
    rate_weight: float = 1e-3  # s^2/rad^2, on the hull's angular and the joints' rates
    # s^2/rad^2, on the hull's angular rates alone, while every thruster is dead: a push off a tip
    # below the centre of mass then turns the hull with nothing else to stop it; at this weight a
    # 1 rad/s spin costs what a 0.05-0.1 m/s approach does. With live thrusters it cost wall-oblique
    # hull contacts, so it is 0 there (experiments/mode3_spin)
    spin_weight: float = 0.1
    # 1/m^2, while every thruster is dead: on the squared distance from the hull's centre of mass to
    # the contact normal's line through the tip (the moment arm by which the wall's push turns the hull).
    # thrusters-dead over 10 s on 90 held-out seeds: hull contacts 9 vs 38 at 0 (experiments/mode3_strut_arm)
    strut_weight: float = 1.0
    hull_clearance: float = 0.05  # m: J_III also pays for the hull closer than this to the contact plane
    clearance_weight: float = 1.0  # 1/s, on that shortfall (the approach speed's weights are 1 to 2)
    clearance_smoothing: float = 0.01  # m, the shortfall's relu
    # deg: with the hull pitched more than this at h0, the problem is solved in Euler angles relative
    # to a frame pitched +-90 deg (ModelOptions.pitch_offset), regular where the world's ZYX angles
    # are singular; the solution comes back in the world's angles. None: always the world's. Past 75
    # deg thrusters-dead's Mode III takes fewer iterations (p95 100 vs 114, fallback steps 50 vs 84),
    # no more hull contacts in 457 runs (8 vs 11), the wall families unchanged (experiments/mode3_regular_pitch)
    regular_pitch: float | None = 75.0
    max_iter: int = 200
    tol: float = 1e-6
    acceptable_iter: int = 3  # IPOPT stops after this many iterations at its acceptable level (0: never)
    ipopt_options: dict = field(default_factory=dict)

    @property
    def horizons(self) -> set[int]:
        """Every horizon Mode III may plan over: with some thruster alive and with every one dead."""
        return {self.horizon, self.thrust_horizon or self.horizon}


@dataclass(frozen=True)
class ModeIIISolution:
    status: SolverStatus
    h: np.ndarray  # (N+1, ns)
    u: np.ndarray  # (N, nu)
    force: np.ndarray  # (N, 3) contact force on the end-effector, obstacle frame [N]
    solve_time: float
    iterations: int
    cost: float
    w: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray


def friction_rows(model: UVMSModel, Rw: np.ndarray, hm: ca.SX, F: ca.SX, s: ModeIIISettings) -> ca.SX:
    """The smooth friction law's two rows (= 0): F_t + mu F_n v_t / sqrt(|v_t|^2 + delta^2), v_t the
    tip's tangential velocity at the midpoint state hm, F in the obstacle frame Rw [N]."""
    v_t = ca.DM(Rw[:, 1:]).T @ (model.jacobian_ee(hm)[:3, :] @ hm[model.n_speeds:])
    return F[1:] + s.friction * F[0] * v_t / ca.sqrt(ca.dot(v_t, v_t) + s.friction_smoothing**2)


def strut_arm(model: UVMSModel, h: ca.SX, plane: Plane) -> ca.SX:
    """(tip - hull's centre of mass) x the plane's normal [m, world]: its norm is the distance from the
    hull's centre of mass to the contact normal's line through the tip, the arm by which the wall's
    push turns the hull."""
    com = h[:3] + model.attitude(h) @ ca.DM(model.params.hull.com)
    return ca.cross(model.ee_pose(h)[0] - com, ca.DM(plane.normal))


def stage_cost(model: UVMSModel, plane: Plane, h1: ca.SX, u: ca.SX, F: ca.SX, wi: ca.SX, s: ModeIIISettings,
               clearance: ca.SX | float | None = None, weight: ca.SX | float | None = None,
               spin: ca.SX | float | None = None, strut: ca.SX | float = 0.0) -> ca.SX:
    """J_III's stage term at the interval's end state h1 (stage weight wi), the hull's shortfall from
    `clearance` [m] weighted by `weight` [1/s], the hull's squared angular rates weighted by `spin`
    [s^2/rad^2] (None: the settings'), the squared distance [m^2] from the hull's centre of mass to the
    contact normal's line through the tip weighted by `strut` [1/m^2], and the regularization."""
    clearance = s.hull_clearance if clearance is None else clearance
    weight = s.clearance_weight if weight is None else weight
    spin = s.spin_weight if spin is None else spin
    d0_dot = model.closing_speeds(h1, ca.DM(plane.normal), plane.offset)[0]
    d0 = model.distances(h1, ca.DM(plane.normal), plane.offset)[0]
    rates = h1[model.n_speeds + 3 :]  # hull angular and joint rates
    arm = strut_arm(model, h1, plane)
    return (
        wi * smooth_relu(-d0_dot, s.approach_smoothing)
        + weight * smooth_relu(clearance - d0, s.clearance_smoothing)
        + s.input_weight * ca.dot(u, u)
        + s.force_weight * ca.dot(F, F)
        + s.rate_weight * ca.dot(rates, rates)
        + spin * ca.dot(rates[:3], rates[:3])
        + strut * ca.dot(arm, arm)
    )


class ModeIIIOCP:
    def __init__(
        self, model: UVMSModel, planes: Sequence[Plane], contact: int, settings: ModeIIISettings = ModeIIISettings()
    ):
        self.model, self.planes, self.contact, self.settings = model, tuple(planes), contact, settings
        self._twins: dict[float, ModeIIIOCP] = {}  # the problem in regular angles, by pitch sign (_twin)
        p, s, N = model.params, settings, settings.horizon
        ns, nu, nv, n = model.n_states, model.n_inputs, model.n_speeds, model.n_joints
        self.ns, self.nu, self.nv, self.nz = ns, nu, nv, ns + nu + nv + 3
        plane = self.planes[contact]
        self.Rw = obstacle_frame(plane.normal)
        h, h1, u, a, F = (
            ca.SX.sym("h", ns),
            ca.SX.sym("h1", ns),
            ca.SX.sym("u", nu),
            ca.SX.sym("a", nv),
            ca.SX.sym("F", 3),
        )
        # h0, water, hull clearance and its weight, the spin and strut weights, stage weight w_i
        P = ca.SX.sym("P", ns + WATER + 4 + 1)
        vc, wi = P[ns : ns + WATER], P[ns + WATER + 4]
        hm = (h + h1) / 2
        friction = friction_rows(model, self.Rw, hm, F, s)
        self._clearance = ca.Function("clear3", [h], [clearances(model, h, self.planes, contact)])
        self.n_clear = self._clearance.size1_out(0)
        cons = ca.vertcat(
            midpoint_residual(model, h, u, a, h1, s.dt, vc, ca.vertcat(F, ca.SX.zeros(3)), ca.DM(self.Rw)),
            tip_gap(model, h1, plane),
            friction,
            self._clearance(h1),
        )
        cost = stage_cost(model, plane, h1, u, F, wi, s, P[ns + WATER], P[ns + WATER + 1], P[ns + WATER + 2],
                          P[ns + WATER + 3])
        st = ca.vertcat(h, u, a, F, h1)
        problem = StageProblem(
            nx=ns,
            nv=nu + nv + 3,
            horizon=N,
            np=ns + WATER + 4,
            np_stage=1,
            cost=ca.Function("cost3", [st, P], [cost]),
            constraints=ca.Function("cons3", [st, P], [cons]),
        )
        ipopt = {
            "print_level": 0,
            "max_iter": s.max_iter,
            "tol": s.tol,
            "mu_init": 1e-2,
            "sb": "yes",
            "acceptable_tol": 1e-2,
            "acceptable_iter": s.acceptable_iter,
            "acceptable_constr_viol_tol": 1e-5,
            **s.ipopt_options,
        }
        name = f"mode3_{p.name}_{p.arm.name}_{plane.name}"
        functions = stage_functions(problem, name)
        self.solver = build_solver(problem, name, ipopt, functions)
        # Warm start from the shifted previous plan and its multipliers (controller.switching): on 35
        # Mode III problems recorded in MuJoCo closed loops the median iteration count fell from 89
        # (Algorithm 2's guess, the cold solver) to 38 when started from the previous solution's own
        # states; with its recomputed states (what the switching NMPC uses) the closed-loop medians
        # were 66 and 132. From Algorithm 2's guess, without multipliers, these
        # options fail: the cold solver stays for that.
        warm = {"warm_start_init_point": "yes", "warm_start_bound_push": 1e-6, "warm_start_mult_bound_push": 1e-6,
                "mu_init": 1e-4}
        self.warm_solver = build_solver(problem, name, {**ipopt, **warm, **s.ipopt_options}, functions)
        self.weights = np.array([1 + (N - i) / (N - 1) if N > 1 else 1.0 for i in range(1, N + 1)])
        # bounds
        lo, hi = p.input_bounds()
        self._lo_u, self._hi_u = lo, hi
        self._q_lo = np.array([lk.joint_range[0] for lk in p.arm.links])
        self._q_hi = np.array([lk.joint_range[1] for lk in p.arm.links])
        self._tau_max = hi[p.n_thrusters :]
        nc = ns + nv + 1 + 2 + self.n_clear
        self.lbg, self.ubg = np.zeros(ns + N * nc), np.zeros(ns + N * nc)
        for k in range(N):
            i = ns + k * nc + ns + nv + 3
            self.lbg[i : i + self.n_clear], self.ubg[i : i + self.n_clear] = s.distance_margin, np.inf
        q = ca.SX.sym("q", n)
        hq = ca.vertcat(ca.SX.sym("pose", 6), q)
        gap = tip_gap(model, ca.vertcat(hq, ca.SX.zeros(nv)), plane)
        self._gap_q = ca.Function("gap_q", [hq], [gap, ca.jacobian(gap, q), ca.hessian(gap, q)[0]])
        pose, q0 = hq[:6], ca.SX.sym("q0", n)
        self._ik = ca.nlpsol("wall_ik", "ipopt", {"x": q, "p": ca.vertcat(pose, q0), "f": ca.sumsqr(q - q0), "g": gap},
                             {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes", "max_iter": 50,
                                                             "tol": 1e-10}})

    def limit_inputs(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Replace the input bounds (e.g. known-failed thrusters: both 0)."""
        self._lo_u, self._hi_u = np.asarray(lo, float), np.asarray(hi, float)
        for twin in self._twins.values():
            twin.limit_inputs(lo, hi)

    def _twin(self, sign: float) -> ModeIIIOCP:
        """This problem with the Euler angles relative to a frame pitched sign * 90 deg (built once)."""
        if sign not in self._twins:
            m = self.model
            pitched = UVMSModel(m.params, m.water, replace(m.options, pitch_offset=sign * np.pi / 2))
            twin = ModeIIIOCP(pitched, self.planes, self.contact, replace(self.settings, regular_pitch=None))
            twin.limit_inputs(self._lo_u, self._hi_u)
            self._twins[sign] = twin
        return self._twins[sign]

    def prepare_twins(self) -> None:
        """Build both pitched twins now (precompilation), not inside the first step pitched past
        `regular_pitch` (tens of seconds on a cold cache)."""
        if self.settings.regular_pitch is not None:
            for sign in (1.0, -1.0):
                self._twin(sign)

    def _angles_to(self, w: np.ndarray, source: UVMSModel, target: UVMSModel) -> np.ndarray:
        """A primal vector with every node's Euler angles re-expressed from source's to target's."""
        w, nz, ns = np.array(w, float), self.nz, self.ns
        nodes = np.concatenate([np.arange(k * nz, k * nz + ns) for k in range(self.settings.horizon + 1)])
        w[nodes] = source.angles_to_options(w[nodes].reshape(-1, ns), target).ravel()
        return w

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        N, nz, ns, nu, n = self.settings.horizon, self.nz, self.ns, self.nu, self.model.n_joints
        lbw, ubw = np.full(N * nz + ns, -np.inf), np.full(N * nz + ns, np.inf)
        for k in range(N + 1):
            i = k * nz
            if k > 0:
                lbw[i + 6 : i + 6 + n], ubw[i + 6 : i + 6 + n] = self._q_lo, self._q_hi
            if k < N:
                lbw[i + ns : i + ns + nu], ubw[i + ns : i + ns + nu] = self._lo_u, self._hi_u
                lbw[i + nz - 3], ubw[i + nz - 3] = 0.0, self.model.params.arm.tip_force_limit  # F_n
        return lbw, ubw

    # ------------------------------------------------------------------------------------------
    def onto_plane(self, h: np.ndarray) -> np.ndarray:
        """Eq. Wall_InvKin: the joint angles nearest to h's (joint limits kept) that put the tip on
        the plane, for h's hull pose. Its optimality conditions, q - q_h + lam grad(q) = 0 and gap(q) = 0
        (one scalar constraint), are solved by Newton's method on (q, lam) with the gap's exact Hessian
        (about 0.1 ms an iteration, quadratic near the solution); where it does not converge within
        the joint range, IPOPT on the 4-variable problem (`onto_plane_ipopt`)."""
        n = self.model.n_joints
        q_h, pose = h[6:6 + n], h[:6]
        q = np.clip(q_h, self._q_lo, self._q_hi)
        lam = None
        for _ in range(IK_NEWTON_ITERATIONS):
            gap, J, H = (np.asarray(v, float) for v in self._gap_q(np.concatenate([pose, q])))
            gap, J = gap.item(), J.ravel()
            if lam is None:  # the multiplier that best fits the first condition at the start
                lam = float(J @ (q_h - q)) / float(J @ J)
            r = np.concatenate([q - q_h + lam * J, [gap]])
            if np.max(np.abs(r)) < 1e-10:
                if np.all((q >= self._q_lo) & (q <= self._q_hi)):
                    return q
                break
            K = np.block([[np.eye(n) + lam * H, J[:, None]], [J[None, :], np.zeros((1, 1))]])
            step = np.linalg.solve(K, -r)
            q, lam = q + step[:n], lam + float(step[n])
        return self.onto_plane_ipopt(h)

    def onto_plane_ipopt(self, h: np.ndarray) -> np.ndarray:
        """`onto_plane` by IPOPT on the 4-variable problem, joint limits as bounds (h's angles if it fails)."""
        n = self.model.n_joints
        q_h = h[6:6 + n]
        r = self._ik(x0=np.clip(q_h, self._q_lo, self._q_hi), p=np.concatenate([h[:6], q_h]), lbx=self._q_lo,
                     ubx=self._q_hi, lbg=0.0, ubg=0.0)
        return np.asarray(r["x"]).ravel() if self._ik.stats()["success"] else q_h.copy()

    def pushing_force(self, h: np.ndarray) -> float:
        """Eq. Fc_Init_OptProblem: the largest normal force [N] the joints can hold statically,
        F_n = min_j tau_max_j / |(J_m^T n)_j|, and at most the jaws' force limit."""
        n = self.model.n_joints
        Jm = np.asarray(self.model.jacobian_ee(h))[:3, 6:]
        arm = np.abs(Jm.T @ self.Rw[:, 0])
        with np.errstate(divide="ignore"):
            held = float(np.min(np.where(arm > 1e-9, self._tau_max / arm, np.inf))) if n else 0.0
        return min(held, self.model.params.arm.tip_force_limit)

    def spin_weight(self) -> float:
        """The hull's spin weight this solve uses [s^2/rad^2]: the settings' while every thruster is
        dead (known-failed: bounds 0), else 0."""
        return self.settings.spin_weight if self._all_dead() else 0.0

    def strut_weight(self) -> float:
        """The strut's moment-arm weight this solve uses [1/m^2]: the settings' while every thruster is
        dead, else 0."""
        return self.settings.strut_weight if self._all_dead() else 0.0

    def _all_dead(self) -> bool:
        nt = self.model.params.n_thrusters
        return not np.any(self._lo_u[:nt]) and not np.any(self._hi_u[:nt])

    def parameters(self, h0: np.ndarray, current: np.ndarray | None = None) -> np.ndarray:
        """The compiled problem's parameter vector for a solve from h0 in `current` [m/s, world]."""
        s = self.settings
        weights = [s.hull_clearance, s.clearance_weight, self.spin_weight(), self.strut_weight()]
        return np.concatenate([h0, water(current), weights, self.weights])

    def away_thrust(self, h: np.ndarray) -> float:
        """The largest force [N] the thrusters, within their bounds (0 for known-failed ones), can
        put on the hull along the contact plane's normal, away from the plane, in attitude h."""
        R = np.asarray(self.model.rotation(h))
        return self.model.params.max_thrust_along(R.T @ self.planes[self.contact].normal, self._lo_u, self._hi_u)

    def stopping_force(self, h: np.ndarray) -> float:
        """Algorithm 2's force, bounded: the smaller of the torque-limited pushing force and the
        normal force that stops the hull's approach within one interval (effective mass along the
        normal from the hull block of M, added mass included) [N]. The pushing force alone, held over
        a 2 s horizon, throws the hull out of the arm's reach within a second and leaves the guess
        90 N off the dynamics."""
        plane = self.planes[self.contact]
        d0_dot = float(np.asarray(self.model.closing_speeds(h, plane.normal, plane.offset)).ravel()[0])
        R = np.asarray(self.model.rotation(h))
        n_body = R.T @ plane.normal
        m_eff = 1.0 / float(n_body @ np.linalg.inv(np.asarray(self.model.mass_matrix(h))[:6, :6])[:3, :3] @ n_body)
        return min(self.pushing_force(h), max(0.0, -d0_dot) * m_eff / self.settings.dt)

    def locked_step(
        self,
        h: np.ndarray,
        thrust: np.ndarray,
        F: np.ndarray,
        dt: float,
        current: np.ndarray | None = None,
        substeps: int = 10,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The model over dt [s] under the thrust and the contact force F (obstacle frame) with the
        joints held rigid by computed torque; returns the state and the mean joint torque [N m]."""
        vc = water(current)
        Fw, taus = np.concatenate([F, np.zeros(3)]), []
        for _ in range(substeps):
            u0 = np.concatenate([thrust, np.zeros(self.model.n_joints)])
            M = np.asarray(self.model.mass_matrix(h))
            Q = np.asarray(sum(self.model.generalized_forces(h, u0, Fw, self.Rw, vc, np.zeros(3)))).ravel()
            a_hull = np.linalg.solve(M[:6, :6], Q[:6])
            tau = M[6:, :6] @ a_hull - Q[6:]
            h = self.model.step(h, np.concatenate([thrust, tau]), dt / substeps, Fw=Fw, Rw=self.Rw, vc=vc)
            taus.append(tau)
        return h, np.mean(taus, axis=0)

    def contact_guess(
        self, h0: np.ndarray, us: np.ndarray, forces: np.ndarray | None, current: np.ndarray | None = None
    ) -> np.ndarray:
        """Algorithm 2: for each stage, the contact force (given, or `stopping_force`), the model
        stepped with it and the inputs' thrust (joints held rigid), the hull's states kept, the arm
        put back on the plane by Wall_InvKin, joint rates zero. Returns the primal vector."""
        s, n, nt = self.settings, self.model.n_joints, self.model.params.n_thrusters
        hs, Fs, Us = [np.asarray(h0, float)], [], []
        for k in range(s.horizon):
            F = forces[k] if forces is not None else np.array([self.stopping_force(hs[-1]), 0.0, 0.0])
            h, tau = self.locked_step(hs[-1], us[k][:nt], F, s.dt, current)
            q = self.onto_plane(h)
            h[6 : 6 + n], h[12 + n :] = q, 0.0  # Algorithm 2: joint rates 0
            hs.append(h)
            Fs.append(F)
            Us.append(np.concatenate([us[k][:nt], np.clip(tau, -self._tau_max, self._tau_max)]))
        return self.pack(np.array(hs), np.array(Us), np.array(Fs))

    def pack(self, hs: np.ndarray, us: np.ndarray, forces: np.ndarray) -> np.ndarray:
        """The primal vector of states (N+1, ns), inputs (N, nu) and contact forces (N, 3), with the
        accelerations of the midpoint rule, (nu_k+1 - nu_k) / dt."""
        nv, dt = self.nv, self.settings.dt
        blocks = [np.concatenate([hs[k], us[k], (hs[k + 1][nv:] - hs[k][nv:]) / dt, forces[k]]) for k in range(len(us))]
        return np.concatenate([*blocks, hs[-1]])

    def shifted_duals(self, sol: ModeIIISolution) -> tuple[np.ndarray, np.ndarray]:
        """The multipliers of `sol` shifted by one interval (the last interval's repeated), to go
        with a primal guess shifted the same way."""
        ns, nz, N = self.ns, self.nz, self.settings.horizon
        lg, lx = sol.lam_g, sol.lam_x
        nc = (len(lg) - ns) // N
        return (np.concatenate([lg[:ns], lg[ns + nc:], lg[-nc:]]),
                np.concatenate([lx[nz:], lx[-nz:-ns], lx[-ns:]]))

    def held_over(self, sol: ModeIIISolution, horizon: int) -> ModeIIISolution:
        """`sol`, a plan over this problem's horizon, held over `horizon` >= it intervals: its last
        interval's inputs, forces and multipliers repeated, its last state repeated at the added nodes
        (a start for a longer problem's warm solve, not a solution of it)."""
        N, ns, nz, extra = self.settings.horizon, self.ns, self.nz, horizon - self.settings.horizon
        if extra < 0:
            raise ValueError(f"horizon {horizon} is shorter than the plan's {N}; allowed: at least {N}")
        nc = (len(sol.lam_g) - ns) // N
        h = np.vstack([sol.h, *[sol.h[-1:]] * extra])
        u, force = np.vstack([sol.u, *[sol.u[-1:]] * extra]), np.vstack([sol.force, *[sol.force[-1:]] * extra])
        w = np.concatenate([sol.w[:N * nz], *[sol.w[(N - 1) * nz:N * nz]] * extra, sol.w[N * nz:]])
        for k in range(N, horizon):  # the repeated blocks start from the plan's last state
            w[k * nz:k * nz + ns] = sol.h[-1]
        lam_g = np.concatenate([sol.lam_g, *[sol.lam_g[-nc:]] * extra])
        lam_x = np.concatenate([sol.lam_x[:N * nz], *[sol.lam_x[(N - 1) * nz:N * nz]] * extra, sol.lam_x[N * nz:]])
        return replace(sol, h=h, u=u, force=force, w=w, lam_g=lam_g, lam_x=lam_x)

    def unpack(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        N, nz, ns, nu = self.settings.horizon, self.nz, self.ns, self.nu
        return (
            np.array([w[k * nz : k * nz + ns] for k in range(N + 1)]),
            np.array([w[k * nz + ns : k * nz + ns + nu] for k in range(N)]),
            np.array([w[(k + 1) * nz - 3 : (k + 1) * nz] for k in range(N)]),
        )

    def solve(
        self,
        h0: np.ndarray,
        guess: np.ndarray,
        current: np.ndarray | None = None,
        duals: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> ModeIIISolution:
        """Solve from h0 with a primal guess; with `duals` (lam_g, lam_x, e.g. `shifted_duals`) by the
        warm-start solver, else by the cold one (Algorithm 2's guess). Pitched over `regular_pitch`,
        in the regular angles of `_twin` (h0, the guess and the solution in the world's)."""
        limit = self.settings.regular_pitch
        if limit is not None and abs(h0[4]) > np.radians(limit):
            twin = self._twin(float(np.sign(h0[4])))
            sol = twin.solve(self.model.angles_to_options(h0, twin.model),
                             self._angles_to(guess, self.model, twin.model), current, duals)
            w = self._angles_to(sol.w, twin.model, self.model)
            return replace(sol, h=self.unpack(w)[0], w=w)
        lbw, ubw = self.bounds()
        s = self.settings
        if s.force_free_gap is not None and self.away_thrust(h0) > 0.0 \
                and float(tip_gap(self.model, h0, self.planes[self.contact])) > s.force_free_gap:
            ubw[self.nz - 3] = 0.0  # F_n of the first interval (its friction rows then zero F_t)
        P = self.parameters(h0, current)
        args = {"x0": np.clip(guess, lbw, ubw), "p": P, "lbx": lbw, "ubx": ubw, "lbg": self.lbg, "ubg": self.ubg}
        solver = self.solver
        if duals is not None:
            args.update(lam_g0=duals[0], lam_x0=duals[1])
            solver = self.warm_solver
        t0 = time.perf_counter()
        r = solver(**args)
        elapsed = time.perf_counter() - t0
        st = solver.stats()
        w = np.asarray(r["x"]).ravel()
        hs, us, Fs = self.unpack(w)
        return ModeIIISolution(
            ipopt_status(st),
            hs,
            us,
            Fs,
            elapsed,
            int(st["iter_count"]),
            float(r["f"]),
            w,
            np.asarray(r["lam_g"]).ravel(),
            np.asarray(r["lam_x"]).ravel(),
        )
