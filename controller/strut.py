"""The steady strut: the state the vehicle can hold with its tip on a plane, found once at contact, as
a target for Mode III's short horizon (a steady-state target, as in offset-free MPC).

Unknowns: the hull's position and pitch (roll and yaw kept at the measured ones), the joint angles,
the inputs within their bounds (failed thrusters 0), a constant speed w of the whole vehicle along
the plane's second tangent (world z on a vertical wall: sliding up or down it), and the tip's normal
force F_n within the jaws' limit. Conditions: no rotation and no acceleration, so the model's
generalized forces balance (weight, buoyancy, drag in the current, the inputs, and the tip's force
F = (F_n, 0, -mu F_n w / sqrt(w^2 + delta^2)) in the obstacle frame: Mode III's smooth friction law);
the tip on the plane; the other links that Mode III keeps off the plane at least its margin off.
Objective: the hull's distance to the plane, largest (plus 1e-2 m^-1 times the squared move from the
measured position, which fixes the position along the plane). IPOPT from the measured joint angles
and from a quarter, half and three quarters of each joint's range; the best converged one is the target.
With its steady state's pitch kept within a bound, the target is an attitude the hull can hold, not
only a far one (maximizing the distance alone turns the hull's long axis away from the plane).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from controller.kinematics import euler_zyx
from controller.model import WATER, UVMSModel
from controller.transcription import obstacle_frame, tip_gap
from uvms.scene import Plane

SLIDE_START = 0.1  # m/s: the start's slide speed, along the net vertical force at rest
POSITION_WEIGHT = 1e-2  # 1/m: the cost of moving the target along the plane (fixes the position there)
STARTS = (0.25, 0.5, 0.75)  # after the measured joint angles: these fractions of each joint's range


@dataclass(frozen=True)
class StrutTarget:
    """A steady strut: the hull's pitch [rad] and the joint angles [rad] to hold, the hull's distance to
    the plane [m] there, the tip's normal force [N] and the slide speed along the plane [m/s]; the
    hull's position [m, world] and the inputs (N, N m) that hold it."""

    pitch: float
    joints: np.ndarray
    clearance: float
    normal_force: float
    slide_speed: float
    position: np.ndarray
    inputs: np.ndarray


class StrutProblem:
    """The steady-strut NLP for one model and contact plane."""

    def __init__(self, model: UVMSModel, plane: Plane, friction: float, friction_smoothing: float,
                 max_pitch: float, margin: float):
        p, n = model.params, model.n_joints
        if n == 0:
            raise ValueError("StrutProblem: the vehicle has no arm; allowed: a model with joints")
        self.model, self.n = model, n
        pos, pitch, w, fn = ca.SX.sym("pos", 3), ca.SX.sym("pitch"), ca.SX.sym("w"), ca.SX.sym("fn")
        q, u = ca.SX.sym("q", n), ca.SX.sym("u", p.n_inputs)
        vc, roll, yaw, pos0 = ca.SX.sym("vc", WATER), ca.SX.sym("roll"), ca.SX.sym("yaw"), ca.SX.sym("pos0", 3)
        Rw = obstacle_frame(plane.normal)
        self._tangent_z = float(Rw[2, 2]) or 1.0  # the slide direction's vertical part (its sign)
        v_body = euler_zyx(roll, pitch, yaw).T @ (w * ca.DM(Rw[:, 2]))
        h = ca.vertcat(pos, roll, pitch, yaw, q, v_body, ca.SX.zeros(3 + n))
        F = ca.vertcat(fn, 0.0, -friction * fn * w / ca.sqrt(w * w + friction_smoothing**2))
        Q = sum(model.generalized_forces(h, u, ca.vertcat(F, ca.SX.zeros(3)), ca.DM(Rw), vc, ca.DM.zeros(3)))
        d = model.distances(h, ca.DM(plane.normal), plane.offset)
        z = ca.vertcat(pos, pitch, q, u, w, fn)
        g = ca.vertcat(Q, tip_gap(model, h, plane), d[1:-1])
        f = -d[0] + POSITION_WEIGHT * ca.sumsqr(pos - pos0)
        self._solver = ca.nlpsol("strut", "ipopt", {"x": z, "p": ca.vertcat(vc, roll, yaw, pos0), "f": f, "g": g},
                                 {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes", "max_iter": 500}})
        self._hull = ca.Function("strut_hull", [z, ca.vertcat(vc, roll, yaw, pos0)], [d[0]])
        nq = model.n_speeds
        self.lbg = np.r_[np.zeros(nq + 1), np.full(n - 1, margin)]
        self.ubg = np.r_[np.zeros(nq + 1), np.full(n - 1, np.inf)]
        self._q_lo = np.array([lk.joint_range[0] for lk in p.arm.links])
        self._q_hi = np.array([lk.joint_range[1] for lk in p.arm.links])
        self._u_lo, self._u_hi = p.input_bounds()
        self.max_pitch, self.tip_force_limit = max_pitch, p.arm.tip_force_limit

    def limit_inputs(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Replace the input bounds (known-failed thrusters: both 0)."""
        self._u_lo, self._u_hi = np.asarray(lo, float), np.asarray(hi, float)

    def solve(self, h: np.ndarray, vc: np.ndarray) -> StrutTarget | None:
        """The target from the measured state h with the water vc (controller.model.water); None when
        no start converges."""
        n, mp = self.n, self.max_pitch
        lbx = np.r_[np.full(3, -np.inf), -mp, self._q_lo, self._u_lo, -1.0, 0.0]
        ubx = np.r_[np.full(3, np.inf), mp, self._q_hi, self._u_hi, 1.0, self.tip_force_limit]
        par = np.r_[vc, h[3], h[5], h[:3]]
        rest = np.r_[h[:self.model.n_speeds], np.zeros(self.model.n_speeds)]
        force = -np.asarray(self.model.bias(rest, vc, np.zeros(3))).ravel()[:3]  # on the hull at rest, body frame
        w0 = np.sign(float((np.asarray(euler_zyx(*h[3:6])) @ force)[2])) * SLIDE_START
        best: tuple[float, np.ndarray] | None = None
        for q0 in (h[6:6 + n], *(self._q_lo + f * (self._q_hi - self._q_lo) for f in STARTS)):
            x0 = np.r_[h[:3], np.clip(h[4], -mp, mp), np.clip(q0, self._q_lo, self._q_hi), np.zeros(len(self._u_lo)),
                       w0 * np.sign(self._tangent_z), 10.0]
            sol = self._solver(x0=x0, p=par, lbx=lbx, ubx=ubx, lbg=self.lbg, ubg=self.ubg)
            if not self._solver.stats()["success"]:
                continue
            z = np.asarray(sol["x"]).ravel()
            clearance = float(self._hull(z, par))
            if best is None or clearance > best[0]:
                best = (clearance, z)
        if best is None:
            return None
        clearance, z = best
        return StrutTarget(float(z[3]), z[4:4 + n].copy(), clearance, float(z[-1]), float(z[-2]), z[:3].copy(),
                           z[4 + n:-2].copy())
