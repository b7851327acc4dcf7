"""The strut: the UVMS at rest with its end-effector on a plane, held there by the water, its weight,
its buoyancy, the contact force and its inputs alone. Not in the paper. Without thrust that can push
the hull off the plane, a rest is where Mode III can hold the hull indefinitely; Mode III's 0.5 s
plans cannot see that far, so its terminal cost pulls the joints towards the strut's
(controller.mode3, `strut_weight`).

Rests form a family: the friction at the tip and the arm's posture balance the contact force's
moment at every pitch (with the alpha4 arm in thrusters-dead's current, the hull 0.19 m off the
wall at 90 deg nose down, 0.47 m at 30 deg nose up, the arm then about horizontal). The
farthest is no target for a hull that the contact is pitching the other way (on development seed
5, J_III pulled towards it let the hull creep onto the wall), so the strut is the far rest near
the measured attitude. The static problem, in the controller's own model (controller.model) with
every speed zero and the water moving at vc (the current and the hull's extra weight in water):
    min -d0 + ATTITUDE_WEIGHT |(roll, pitch) - measured|^2 + TANGENTIAL_WEIGHT |along-plane offset|^2
    s.t. Q(h, u, F) = 0 (every generalized force: hull and joints), the tip on the plane,
         0 <= F_n <= the jaws' limit, |F_t,i| <= mu F_n (a friction pyramid), every other body at
         least `margin` off every plane, the joints within their ranges, u within its bounds,
with d0 the hull's distance to the plane [m], over the hull's position, roll and pitch (its yaw
held at the measured one: nothing restores yaw), the joint angles, the inputs and the contact force
F (obstacle frame), by IPOPT from the previous strut (the same rest followed as the vehicle moves)
or, without one or if that fails, from the measured posture and from the arm straightened (each
with the hull moved along the normal until the tip touches the plane), keeping the better.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np

from controller.model import UVMSModel, water
from controller.transcription import clearances, obstacle_frame, tip_gap
from uvms.scene import Plane

# 1/m: the strut's position along the plane is not determined by rest (the contact's friction holds
# the hull's weight in water); this small weight keeps it at the measured one
TANGENTIAL_WEIGHT = 1e-2
# m/rad^2: the price of the strut's roll and pitch away from the measured ones
ATTITUDE_WEIGHT = 1.0


@dataclass(frozen=True)
class Strut:
    """A static equilibrium with the tip on the plane."""

    h: np.ndarray  # (n_s,) the state at rest (speeds 0)
    u: np.ndarray  # (n_u,) the inputs that hold it [N, N m]
    force: np.ndarray  # (3,) contact force on the end-effector, obstacle frame [N]
    distance: float  # the hull's distance to the plane [m]


class StrutProblem:
    def __init__(self, model: UVMSModel, planes: Sequence[Plane], contact: int, friction: float, margin: float):
        self.model, self.planes, self.contact = model, tuple(planes), contact
        p, n = model.params, model.n_joints
        plane = self.planes[contact]
        pos, rp, q, u, F = (ca.SX.sym(k, m) for k, m in (("pos", 3), ("rp", 2), ("q", n), ("u", p.n_inputs),
                                                             ("F", 3)))
        att, at, vc = ca.SX.sym("att", 3), ca.SX.sym("at", 3), ca.SX.sym("vc", len(water()))
        h = ca.vertcat(pos, rp, att[2], q, ca.SX.zeros(model.n_speeds))
        Q = model.generalized_forces(h, u, ca.vertcat(F, ca.SX.zeros(3)), ca.DM(obstacle_frame(plane.normal)), vc,
                                     ca.DM.zeros(3))
        d0 = model.distances(h, ca.DM(plane.normal), plane.offset)[0]
        clear = clearances(model, h, self.planes, contact)
        g = ca.vertcat(sum(Q, ca.SX.zeros(model.n_speeds)), tip_gap(model, h, plane),
                       F[1:] - friction * F[0], F[1:] + friction * F[0], clear)
        self._x = ca.vertcat(pos, rp, q, u, F)
        along = ca.DM(np.eye(3) - np.outer(plane.normal, plane.normal)) @ (pos - at)
        f = -d0 + TANGENTIAL_WEIGHT * ca.dot(along, along) + ATTITUDE_WEIGHT * ca.sumsqr(rp - att[:2])
        self._solver = ca.nlpsol("strut", "ipopt", {"x": self._x, "p": ca.vertcat(att, at, vc), "f": f, "g": g},
                                 {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes", "max_iter": 200}})
        self._state = ca.Function("strut_state", [self._x, att], [h, d0])
        hs = ca.SX.sym("h", model.n_states)
        self._gap = ca.Function("strut_gap", [hs], [tip_gap(model, hs, plane)])
        n_eq = model.n_speeds + 1
        self._lbg = np.r_[np.zeros(n_eq), np.full(2, -np.inf), np.zeros(2), np.full(clear.size1(), margin)]
        self._ubg = np.r_[np.zeros(n_eq), np.zeros(2), np.full(2, np.inf), np.full(clear.size1(), np.inf)]
        lo, hi = p.input_bounds()
        q_lo = [lk.joint_range[0] for lk in p.arm.links]
        q_hi = [lk.joint_range[1] for lk in p.arm.links]
        self._lbx = np.r_[np.full(3, -np.inf), -np.pi / 2, -np.pi / 2, q_lo, lo, 0.0, -np.inf, -np.inf]
        self._ubx = np.r_[np.full(3, np.inf), np.pi / 2, np.pi / 2, q_hi, hi, p.arm.tip_force_limit, np.inf, np.inf]
        self._nu = p.n_inputs

    def limit_inputs(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Replace the input bounds (e.g. known-failed thrusters: both 0)."""
        n = self.model.n_joints
        self._lbx[5 + n:5 + n + self._nu], self._ubx[5 + n:5 + n + self._nu] = lo, hi

    def solve(self, h: np.ndarray, current: np.ndarray | None = None, previous: Strut | None = None) -> Strut | None:
        """The strut from `previous` (the same rest followed as the water changes) or, without it or
        if that start fails, the better of those from h's posture and from the arm straight; the
        water at `current` (controller.model.water's input). None if no start converges."""
        if previous is not None:
            found = self._best(h, current, [np.r_[previous.h[:5], previous.h[6:6 + self.model.n_joints], previous.u,
                                                  previous.force]])
            if found is not None:
                return found
        n, normal, starts = self.model.n_joints, self.planes[self.contact].normal, []
        for q0 in (h[6:6 + n], np.zeros(n)):
            start = np.r_[h[:6], np.clip(q0, self._lbx[5:5 + n], self._ubx[5:5 + n]), np.zeros(self.model.n_speeds)]
            start[:3] -= float(self._gap(start)) * normal  # the hull moved along the normal: the tip on the plane
            starts.append(np.r_[start[:5], start[6:6 + n], np.zeros(self._nu), 0.0, 0.0, 0.0])
        return self._best(h, current, starts)

    def _best(self, h: np.ndarray, current: np.ndarray | None, starts: list[np.ndarray]) -> Strut | None:
        """The farthest rest IPOPT reaches from the starts (None: it converges from none)."""
        n, vc = self.model.n_joints, water(current)
        best: tuple[float, np.ndarray] | None = None
        for x0 in starts:
            r = self._solver(x0=x0, p=np.r_[h[3:6], h[:3], vc], lbx=self._lbx, ubx=self._ubx,
                             lbg=self._lbg, ubg=self._ubg)
            if self._solver.stats()["success"] and (best is None or -float(r["f"]) > best[0]):
                best = (-float(r["f"]), np.asarray(r["x"]).ravel())
        if best is None:
            return None
        x = best[1]
        state, d0 = self._state(x, h[3:6])
        return Strut(np.asarray(state).ravel(), x[5 + n:5 + n + self._nu], x[-3:], float(d0))
