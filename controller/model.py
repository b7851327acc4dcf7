"""The paper's UVMS model (Section III) by Kane's method in CasADi, from the parameter file.

Generalized speeds nu = [v, omega, qdot_m]: hull body-frame linear and angular velocity and joint
rates; state h = [x y z phi theta psi q_m | nu]. For every body k Kane's method takes the partial
velocities V_k = d v_k / d nu of its points and the partial angular velocities W_k = d omega_k / d nu
(here by CasADi's exact differentiation of the velocity expressions, which are linear in nu), and
sums the generalized active forces sum V^T F + W^T T against the generalized inertia forces
sum V^T m a + W^T (I alpha + omega x I omega), all expressed in the hull frame B (Tarn et al. 1996).
Accelerations are inertial ones expressed in B: a = d/dt(v_B) + omega x v_B.

Forces: gravity at each CoM; buoyancy rho V g at each centre of buoyancy; added mass of the hull
(Fossen's diagonal M_A about the hull origin) and of every link (cross-flow, about its centre), on
the velocity relative to the current, with their Coriolis and centripetal terms (Fossen 2011,
eq. 6.43, applied per body in its own frame); Froude-Krylov force rho V a_current for a
time-varying current; hull drag (Fossen linear + quadratic, relative velocity); link cross-flow
drag integrated along each link by Gauss-Legendre points (so it yields moments); thrusters through
the allocation matrix; joint torques and rotor inertias; the end-effector contact wrench given in
the obstacle frame (paper eq. F_contact: J_v^T blockdiag(R_w, R_w) F^w); and a hull weight in water
beyond the parameters' (a vertical force at the hull's CoM: the slot in which controller.estimator
puts a hull heavier or lighter in water than its model).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from controller.codegen import NumpyCall, compiled
from controller.kinematics import euler_rates, euler_zyx, link_frames, skew
from controller.superellipsoid import closing_speed, plane_distance, superellipsoid_mesh
from uvms.params import UVMSParams
from uvms.scene import Water

# A link's superellipsoid frame in its link frame: x_se = y_link, y_se = z_link, z_se = x_link (columns).
LINK_TO_SUPERELLIPSOID = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
WATER = 4  # entries of the model's `vc` input: the current (3, world, m/s), the hull's extra weight in water (N)
TERMS = ("coriolis", "gravity", "buoyancy", "added_mass", "froude_krylov", "drag", "thrust", "joint_torque",
         "contact")


@dataclass(frozen=True)
class ModelOptions:
    """Switches for physics experiments; the defaults are the paper's full model."""

    gravity: bool = True
    buoyancy: bool = True
    added_mass: bool = True
    drag: bool = True
    rotor_inertia: bool = True
    # the joints' viscous friction, the parameter file's `joint_damping` [N m s/rad] (the plant's
    # gearbox friction; not in the paper's model)
    joint_damping: bool = False
    abs_smoothing: float = 1e-4  # m/s or rad/s: |x| ~ sqrt(x^2 + s^2) in the drag laws (smooth NLPs)
    # m: |w| ~ sqrt(w^2 + s^2) in the superellipsoids' support function (controller.superellipsoid): the
    # distances err on the safe side by <= 3 s (the default bodies: <= 0.9 mm). At controller.superellipsoid's
    # DELTA = 1e-7 m the distance of a face parallel to a plane has a curvature spike that makes IPOPT
    # oscillate: the certificate's minimum-violation problem fails on 5 of 42 labelled cases that F calls
    # feasible, and on none at 1e-3 m (docs/decisions.md, 'Superellipsoids' support function smoothed')
    support_smoothing: float = 1e-3
    link_drag_points: int = 3  # Gauss-Legendre points per link for cross-flow drag
    # rad: the state's Euler angles give the hull's attitude relative to a frame pitched by this angle
    # about the world's y axis (R = Ry(offset) Rz Ry Rx). 0: the world's ZYX angles, singular at pitch
    # +-90 deg; with pi/2 the angles are regular there (and singular at a level hull heading +-x)
    pitch_offset: float = 0.0


class ModelError(ValueError):
    """The parameters cannot make a valid model (singular M, degenerate link, no volume)."""


def _sabs(x: ca.SX, s: float) -> ca.SX:
    return ca.sqrt(x * x + s * s)


class UVMSModel:
    """CasADi functions of the paper's model; each also callable with numpy arrays.

    Inputs of the dynamics: h (n_s), u (n_u: thruster forces N, joint torques N m), Fw (6: contact
    force N and torque N m at the end-effector, obstacle frame), Rw (3x3: obstacle frame -> world),
    vc (WATER = 4: the current's velocity, world, m/s; then the hull's weight in water beyond the
    parameters', N, downwards), ac (3: the current's time derivative, m/s^2). Numpy callers may
    give vc as the current alone (3 values: no extra weight); `water()` makes the 4 values.
    """

    def __init__(self, params: UVMSParams, water: Water, options: ModelOptions = ModelOptions()):
        self.params, self.water, self.options = params, water, options
        _validate(params)
        n = params.n_joints
        self.n_joints, self.n_speeds, self.n_states, self.n_inputs = n, 6 + n, 2 * (6 + n), params.n_inputs
        h = ca.SX.sym("h", self.n_states)
        u = ca.SX.sym("u", self.n_inputs)
        Fw, Rw = ca.SX.sym("Fw", 6), ca.SX.sym("Rw", 3, 3)
        vc, ac = ca.SX.sym("vc", WATER), ca.SX.sym("ac", 3)
        dt = ca.SX.sym("dt")
        M, terms, kin = self._kane(h, u, Fw, Rw, vc, ac)
        rhs = sum(terms.values(), ca.SX.zeros(self.n_speeds))
        nu_dot = ca.solve(M, rhs)
        eta_dot = ca.vertcat(kin["R"] @ h[n + 6:n + 9], euler_rates(h[3:6], h[n + 9:n + 12]), h[12 + n:])
        hdot = ca.vertcat(eta_dot, nu_dot)
        args, names = [h, u, Fw, Rw, vc, ac], ["h", "u", "Fw", "Rw", "vc", "ac"]
        self.f = ca.Function("f", args, [hdot], names, ["hdot"])
        self.mass_matrix = ca.Function("M", [h], [M], ["h"], ["M"])
        self.rotation = ca.Function("R", [h], [kin["R"]], ["h"], ["R"])
        self.generalized_forces = ca.Function("Q", args, list(terms.values()), names, list(terms))
        inputs = ("thrust", "joint_torque", "contact")
        passive = sum((v for k, v in terms.items() if k not in inputs), ca.SX.zeros(self.n_speeds))
        self.bias = ca.Function("bias", [h, vc, ac], [-passive], ["h", "vc", "ac"], ["bias"])
        self.ee_pose = ca.Function("ee_pose", [h], [kin["x_ee"], kin["R_ee"]], ["h"], ["x_ee", "R_ee"])
        self.jacobian_ee = ca.Function("Jv", [h], [kin["Jv"]], ["h"], ["Jv"])
        self.link_poses = ca.Function("link_poses", [h], kin["link_x"] + kin["link_R"])
        self.body_names = ("hull", *(lk.name for lk in params.arm.links))
        self._distance_functions(h, kin)
        self.rk4 = self._rk4(h, u, Fw, Rw, vc, ac, dt)
        self._rk4_compiled: NumpyCall | None = None
        self._held: dict[int, NumpyCall] = {}  # held_steps' compiled functions, by number of substeps
        self._mass_bias: NumpyCall | None = None

    # ------------------------------------------------------------------------------------------
    def attitude(self, h: ca.SX) -> ca.SX:
        """The hull's rotation (body to world) from the state's Euler angles (ModelOptions.pitch_offset)."""
        R = euler_zyx(h[3], h[4], h[5])
        off = self.options.pitch_offset
        return R if off == 0.0 else ca.DM(_rot_y(off)) @ R

    def angles_to_options(self, h: np.ndarray, other: UVMSModel) -> np.ndarray:
        """State(s) h (..., ns) of this model with the Euler angles re-expressed for `other`'s offset."""
        h = np.array(h, float)
        d = self.options.pitch_offset - other.options.pitch_offset
        for x in h.reshape(-1, h.shape[-1]):
            x[3:6] = _zyx_angles(_rot_y(d) @ _zyx_matrix(*x[3:6]))
        return h

    def _kane(self, h, u, Fw, Rw, vc, ac):
        p, o, w = self.params, self.options, self.water
        n, N = self.n_joints, self.n_speeds
        qm, nu = h[6:6 + n], h[6 + n:]
        v, om, qd = nu[0:3], nu[3:6], nu[6:]
        R = self.attitude(h)
        g_B = R.T @ ca.DM([0.0, 0.0, -w.gravity])
        vc_B, ac_B = R.T @ vc[:3], R.T @ ac
        fr = link_frames(p, qm)
        terms = {k: ca.SX.zeros(N) for k in TERMS}
        M = ca.SX.zeros(N, N)

        def point_velocity(pos: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
            """Inertial velocity (in B) of a point at pos(q_m), its partial velocities, and its
            acceleration with nu_dot = 0."""
            vel = v + ca.cross(om, pos) + ca.jacobian(pos, qm) @ qd if n else v + ca.cross(om, pos)
            acc0 = (ca.jacobian(vel, qm) @ qd if n else 0) + ca.cross(om, vel)
            return vel, ca.jacobian(vel, nu), acc0

        # Bodies: the hull (k = -1) and the links. Angular velocity, its partials and alpha(nu_dot=0).
        bodies = [("hull", ca.SX.eye(3), om, None)]
        w_rel = om
        for k, lk in enumerate(p.arm.links):
            w_rel = w_rel + fr.z[k] * qd[k]
            bodies.append((lk.name, fr.C[k], w_rel, k))

        se_c, se_R, se_v, se_w = [], [], [], []
        P = ca.DM(LINK_TO_SUPERELLIPSOID)
        for _name, C, omk, k in bodies:
            # the body's superellipsoid: centre, rotation (world), centre velocity (world), omega (its frame)
            centre_B = ca.DM.zeros(3) if k is None else fr.point(k, [p.arm.links[k].length / 2, 0.0, 0.0])
            vel_c, Vc, accc0 = point_velocity(centre_B)
            Rse = C if k is None else C @ P
            se_c.append(h[0:3] + R @ centre_B)
            se_R.append(R @ Rse)
            se_v.append(R @ vel_c)
            se_w.append(Rse.T @ omk)
            W = ca.jacobian(omk, nu)
            alpha0 = (ca.jacobian(omk, qm) @ qd if n else 0) + ca.cross(om, omk)
            if k is None:
                mass, com, cob, vol, inertia = p.hull.mass, ca.DM(p.hull.com), ca.DM(p.hull.cob), p.hull.volume, \
                    ca.DM(p.hull.inertia)
                pos = lambda r: ca.DM(r)  # noqa: E731
            else:
                lk = p.arm.links[k]
                mass, vol, inertia = lk.mass, lk.volume, C @ ca.DM(np.diag(lk.inertia)) @ C.T
                pos = lambda r, k=k: fr.point(k, r)  # noqa: E731
                com, cob = pos(lk.com), pos(lk.cob)
            # rigid body
            _, V, acc0 = point_velocity(com)
            M += mass * V.T @ V + W.T @ inertia @ W
            terms["coriolis"] -= mass * V.T @ acc0 + W.T @ (inertia @ alpha0 + ca.cross(omk, inertia @ omk))
            _, Vb, _ = point_velocity(cob)
            if o.gravity:
                terms["gravity"] += V.T @ (mass * g_B)
                if k is None:  # the hull's extra weight in water, at its CoM
                    terms["gravity"] += V.T @ (vc[3] * g_B / w.gravity)
                if o.buoyancy:
                    terms["buoyancy"] -= Vb.T @ (w.density * vol * g_B)
            terms["froude_krylov"] += Vb.T @ (w.density * vol * ac_B)
            # added mass about the body's hydrodynamic centre (its superellipsoid's), in its own frame
            if o.added_mass:
                A = p.hull.added_mass if k is None else lk.added_mass(w.density)
                Al, Aa = ca.DM(A[:3]), ca.DM(A[3:])
                ur, wr = C.T @ (vel_c - vc_B), C.T @ omk
                M += Vc.T @ C @ ca.diag(Al) @ C.T @ Vc + W.T @ C @ ca.diag(Aa) @ C.T @ W
                udot0 = C.T @ (accc0 - ac_B) - ca.cross(wr, ur)
                F = -Al * udot0 + ca.cross(Al * ur, wr)
                T = -Aa * (C.T @ alpha0) + ca.cross(Al * ur, ur) + ca.cross(Aa * wr, wr)
                terms["added_mass"] += Vc.T @ (C @ F) + W.T @ (C @ T)
            if o.drag:
                terms["drag"] += self._drag(k, C, point_velocity, pos, omk, vc_B)

        if o.rotor_inertia:
            for k, lk in enumerate(p.arm.links):
                M[6 + k, 6 + k] += lk.rotor_inertia
        if o.joint_damping:
            terms["joint_damping"] = ca.vertcat(ca.SX.zeros(6), -ca.DM([lk.joint_damping for lk in p.arm.links])
                                                * qd)
        n_thr = p.n_thrusters
        terms["thrust"] = ca.vertcat(ca.DM(p.allocation_matrix()) @ u[:n_thr], ca.SX.zeros(n))
        terms["joint_torque"] = ca.vertcat(ca.SX.zeros(6), u[n_thr:])
        # end-effector point and the contact wrench (paper eq. F_contact)
        if n:
            p_ee = fr.point(n - 1, p.arm.end_effector)
            C_last, om_last = bodies[-1][1], bodies[-1][2]
        else:
            p_ee, C_last, om_last = ca.DM.zeros(3), ca.SX.eye(3), om
        _, V_ee, _ = point_velocity(p_ee)
        W_last = ca.jacobian(om_last, nu)
        terms["contact"] = V_ee.T @ (R.T @ Rw @ Fw[:3]) + W_last.T @ (R.T @ Rw @ Fw[3:])
        x = h[0:3]
        kin = {
            "R": R,
            "x_ee": x + R @ p_ee,
            "R_ee": R @ C_last,
            "Jv": ca.vertcat(R @ V_ee, R @ W_last),
            "link_x": [x + R @ fr.o[k] for k in range(n)],
            "link_R": [R @ fr.C[k] for k in range(n)],
            "se_c": se_c, "se_R": se_R, "se_v": se_v, "se_w": se_w,
        }
        return M, terms, kin

    def _distance_functions(self, h: ca.SX, kin: dict) -> None:
        """Signed distance of every body's superellipsoid to a plane n.x + D = 0 and its closing
        speed (paper eq. Distance), in body order hull, links."""
        normal, offset = ca.SX.sym("n", 3), ca.SX.sym("D")
        shapes = [self.params.hull.superellipsoid] + [lk.superellipsoid for lk in self.params.arm.links]
        d, dd, s = [], [], self.options.support_smoothing
        for se, c, Rse, v, w in zip(shapes, kin["se_c"], kin["se_R"], kin["se_v"], kin["se_w"], strict=True):
            d.append(plane_distance(ca.DM(se.semi_axes), se.eps1, se.eps2, c, Rse, normal, offset, s))
            dd.append(closing_speed(ca.DM(se.semi_axes), se.eps1, se.eps2, Rse, normal, v, w, s))
        self.distances = ca.Function("distances", [h, normal, offset], [ca.vertcat(*d)], ["h", "n", "D"], ["d"])
        self.closing_speeds = ca.Function("closing_speeds", [h, normal, offset], [ca.vertcat(*dd)],
                                          ["h", "n", "D"], ["d_dot"])
        self.superellipsoid_poses = ca.Function("superellipsoid_poses", [h], kin["se_c"] + kin["se_R"])

    def _drag(self, k, C, point_velocity, pos, omk, vc_B) -> ca.SX:
        p, s = self.params, self.options.abs_smoothing
        if k is None:
            vel, _, _ = point_velocity(ca.DM.zeros(3))
            ur, wr = vel - vc_B, omk
            lin, quad = p.hull.linear_damping, p.hull.quadratic_damping
            F = -(ca.DM(lin[:3]) + ca.DM(quad[:3]) * _sabs(ur, s)) * ur
            T = -(ca.DM(lin[3:]) + ca.DM(quad[3:]) * _sabs(wr, s)) * wr
            return ca.vertcat(F, T, ca.SX.zeros(self.n_joints))
        lk = p.arm.links[k]
        xs, ws = np.polynomial.legendre.leggauss(self.options.link_drag_points)
        Q = ca.SX.zeros(self.n_speeds)
        for xi, wi in zip(xs, ws, strict=True):
            sx = 0.5 * lk.length * (xi + 1)
            vel, V, _ = point_velocity(pos([sx, 0.0, 0.0]))
            ur = C.T @ (vel - vc_B)
            cross = ca.vertcat(0, ur[1], ur[2])
            speed = ca.sqrt(ur[1] ** 2 + ur[2] ** 2 + s * s)
            f = -0.5 * self.water.density * lk.drag_coefficient * 2 * lk.radius * speed * cross
            Q += V.T @ (C @ f) * (0.5 * lk.length * wi)
        return Q

    def _rk4(self, h, u, Fw, Rw, vc, ac, dt) -> ca.Function:
        """One RK4 step of duration dt [s] (an input: Mode II optimizes it), inputs held."""
        def f(x):
            return self.f(x, u, Fw, Rw, vc, ac)

        k1 = f(h)
        k2 = f(h + dt / 2 * k1)
        k3 = f(h + dt / 2 * k2)
        k4 = f(h + dt * k3)
        h_next = h + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return ca.Function("rk4", [h, u, Fw, Rw, vc, ac, dt], [h_next], ["h", "u", "Fw", "Rw", "vc", "ac", "dt"],
                           ["h_next"])

    def body_meshes(self, resolution: int = 64) -> dict:
        """trimesh meshes of every body's superellipsoid in its own frame (place them with
        `superellipsoid_poses(h)`: centres, then rotations), for visualisation."""
        shapes = [self.params.hull.superellipsoid] + [lk.superellipsoid for lk in self.params.arm.links]
        return {name: superellipsoid_mesh(se.semi_axes, se.eps1, se.eps2, resolution)
                for name, se in zip(self.body_names, shapes, strict=True)}

    # ------------------------------------------------------------------------------------------
    def defaults(self, Fw=None, Rw=None, vc=None, ac=None) -> tuple[np.ndarray, ...]:
        """Fill the optional inputs: no contact, identity obstacle frame, still water."""
        return (np.zeros(6) if Fw is None else Fw, np.eye(3) if Rw is None else Rw,
                water(vc), np.zeros(3) if ac is None else ac)

    def hdot(self, h, u, Fw=None, Rw=None, vc=None, ac=None) -> np.ndarray:
        """State derivative from numpy arrays."""
        return np.asarray(self.f(h, u, *self.defaults(Fw, Rw, vc, ac))).ravel()

    def step(self, h, u, dt: float, Fw=None, Rw=None, vc=None, ac=None) -> np.ndarray:
        """One RK4 step from numpy arrays: `rk4` compiled to C on first use (about 5 s, then cached
        on disk; controller.codegen) and called without conversions, about 12x faster than the SX
        function (bench/results/model_eval.md)."""
        if self._rk4_compiled is None:
            name = f"rk4_{self.params.name}_{self.params.arm.name}"
            self._rk4_compiled = NumpyCall(compiled([self.rk4], name)["rk4"])
        Fw, Rw, vc, ac = self.defaults(Fw, Rw, vc, ac)
        out = self._rk4_compiled(h, u, Fw, np.asarray(Rw, float).T, vc, ac, np.array([dt], float))
        return out[0].copy()

    def mass_and_bias(self, h, vc=None) -> tuple[np.ndarray, np.ndarray]:
        """The mass matrix M(q) and the bias (N, N m; `bias` with the water moving at vc [m/s])
        from numpy arrays, in one compiled call (the SX functions' values, without their per-call cost)."""
        if self._mass_bias is None:
            h_, vc_, ac_ = (ca.SX.sym(n, self.bias.size_in(i)) for i, n in enumerate(("h", "vc", "ac")))
            mb = ca.Function("mass_bias", [h_, vc_, ac_], [self.mass_matrix(h_), self.bias(h_, vc_, ac_)])
            self._mass_bias = NumpyCall(compiled([mb], f"mass_bias_{self.params.name}_{self.params.arm.name}")[
                "mass_bias"])
        _, _, vc, ac = self.defaults(None, None, vc, None)
        M, b = self._mass_bias(h, vc, ac)
        n = self.n_speeds
        return M.reshape(n, n, order="F").copy(), b.copy()

    def held_steps(self, h, u, dt: float, substeps: int, Fw=None, Rw=None, vc=None) -> np.ndarray:
        """`substeps` RK4 steps of dt / substeps [s] each, u (and the contact wrench Fw in frame Rw,
        as in `step`) held, in one compiled call:
        `step` called `substeps` times (the same C code for each step, so the same arithmetic),
        without its per-call overhead (about 4x fewer calls from Python in a rollout)."""
        if substeps not in self._held:
            args = [ca.MX.sym(n, self.rk4.size_in(i)) for i, n in enumerate(("h", "u", "Fw", "Rw", "vc", "ac", "dt"))]
            x = args[0]
            for _ in range(substeps):
                x = self.rk4(x, *args[1:6], args[6] / substeps)
            held = ca.Function(f"held{substeps}", args, [x])
            name = f"held{substeps}_{self.params.name}_{self.params.arm.name}"
            self._held[substeps] = NumpyCall(compiled([held], name)[held.name()])
        Fw, Rw, vc, ac = self.defaults(Fw, Rw, vc, None)
        return self._held[substeps](h, u, Fw, np.asarray(Rw, float).T, vc, ac, np.array([dt], float))[0].copy()


# The pitched attitude's own helpers: kinematics.rot_axis and uvms.conventions' conversions give the same
# rotations to the last digits, and those digits change the closed loops measured in experiments/mode3_regular_pitch
def _rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _zyx_matrix(phi: float, theta: float, psi: float) -> np.ndarray:
    return np.asarray(ca.DM(euler_zyx(phi, theta, psi)))


def _zyx_angles(R: np.ndarray) -> np.ndarray:
    """(phi, theta, psi) with R = Rz(psi) Ry(theta) Rx(phi), theta in [-pi/2, pi/2]."""
    theta = -np.arcsin(np.clip(R[2, 0], -1.0, 1.0))
    return np.array([np.arctan2(R[2, 1], R[2, 2]), theta, np.arctan2(R[1, 0], R[0, 0])])


def water(current=None, extra_weight: float = 0.0) -> np.ndarray:
    """The model's `vc` input (WATER values) from a current [m/s, world] and the hull's extra weight
    in water [N]: `current` may be None (still water), 3 values, or already the WATER values (then
    `extra_weight` must be 0)."""
    if current is None:
        current = np.zeros(3)
    c = np.asarray(current, float).ravel()
    if c.size == WATER:
        if extra_weight != 0.0:
            raise ValueError(f"extra_weight {extra_weight} N given with {WATER} values that hold one; allowed: 0")
        return c.copy()
    if c.size != 3:
        raise ValueError(f"current has {c.size} values; allowed: 3 (m/s, world) or {WATER} (with the extra weight)")
    return np.concatenate([c, [float(extra_weight)]])


def _validate(p: UVMSParams) -> None:
    """Reject parameters that cannot make a model (one clear line each)."""
    if p.hull.volume <= 0:
        raise ModelError(f"hull volume {p.hull.volume} m^3: a body with no volume; allowed: > 0")
    for lk in p.arm.links:
        if lk.length <= 0:
            raise ModelError(f"link {lk.name!r} has length {lk.length} m; allowed: > 0")
        if lk.volume <= 0:
            raise ModelError(f"link {lk.name!r} has volume {lk.volume} m^3: a body with no volume; allowed: > 0")
    eig = np.linalg.eigvalsh(np.asarray(p.hull.inertia))
    if p.hull.mass <= 0 or eig.min() <= 0:
        raise ModelError(f"hull mass {p.hull.mass} kg / inertia eigenvalues {eig}: M would be singular; "
                         "allowed: positive mass and positive-definite inertia")
    for lk in p.arm.links:
        if lk.mass <= 0 or np.min(lk.inertia) <= 0:
            raise ModelError(f"link {lk.name!r}: mass {lk.mass} kg, inertia {lk.inertia.tolist()}: M would be "
                             "singular; allowed: positive mass and inertia")


__all__ = ["TERMS", "WATER", "ModelError", "ModelOptions", "UVMSModel", "skew", "water"]
