"""Model rollouts under simple feedback policies: the feasibility screen's maximum braking and the
initial guesses of Modes II and III. A policy's rollouts are compiled to C as one call each
(`BrakingPolicy.rollout`: about 1 ms for 20 intervals, against 8 ms stepping in numpy)."""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from controller.codegen import NumpyCall, compiled
from controller.model import WATER, UVMSModel, water
from uvms.scene import Plane

ATTITUDE_STIFFNESS = 20.0  # N m/rad: the braking policy's level roll and pitch hold
ATTITUDE_DAMPING = 5.0  # N m s/rad: the same hold on the angular rates


@dataclass(frozen=True)
class JointHold:
    """Joint PD towards a posture, on top of computed torque (N m/rad, N m s/rad)."""

    stiffness: float = 1.0
    damping: float = 0.1


class BrakingPolicy:
    """Maximum braking with attitude hold. The thrusters first serve an attitude PD (level roll and
    pitch, heading and angular rates held; ATTITUDE_STIFFNESS, ATTITUDE_DAMPING), and the largest
    force against the hull's body velocity that the remaining thruster range allows is added. Joint torques by
    computed torque: those that make the joints' acceleration zero under this thrust
    (M [a_hull; 0] + b = [B u; tau]), plus a PD to `posture` [rad], within the torque limits."""

    def __init__(self, model: UVMSModel, hold: JointHold = JointHold()):
        p = model.params
        self.model, self.hold = model, hold
        self._B = p.allocation_matrix()
        self._pinv = np.linalg.pinv(self._B)
        self._thrust_limit = np.array([t.force_range for t in p.thrusters])
        self._lo, self._hi = p.input_bounds()
        self._compiled: dict[tuple, NumpyCall] = {}

    def limit_thrust(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Replace the input bounds (thrusters first; e.g. known-failed thrusters: both 0)."""
        nt = self.model.params.n_thrusters
        self._thrust_limit = np.column_stack([lo[:nt], hi[:nt]])
        self._lo, self._hi = np.asarray(lo, float), np.asarray(hi, float)

    def law(self) -> ca.Function:
        """The policy as a CasADi function u(h, posture, vc, lo, hi) of the state, the posture [rad],
        the water (model.water: current [m/s], extra hull weight [N]) and the input bounds:
        `__call__`'s arithmetic, for compiled rollouts."""
        model, n, nt = self.model, self.model.n_joints, self.model.params.n_thrusters
        h, posture = ca.SX.sym("h", model.n_states), ca.SX.sym("posture", n)
        vc, lo, hi = ca.SX.sym("vc", WATER), ca.SX.sym("lo", model.n_inputs), ca.SX.sym("hi", model.n_inputs)
        pinv, B = ca.DM(self._pinv), ca.DM(self._B)
        v, w = h[6 + n:9 + n], h[9 + n:12 + n]
        hold = ca.vertcat(ca.DM.zeros(3), -ATTITUDE_STIFFNESS * ca.vertcat(h[3], h[4], 0.0) - ATTITUDE_DAMPING * w)
        lo_t, hi_t = lo[:nt], hi[:nt]
        base = ca.fmin(ca.fmax(pinv @ hold, lo_t), hi_t)
        brake = pinv @ ca.vertcat(-v, ca.DM.zeros(3))
        room = ca.if_else(brake > 0, hi_t - base, lo_t - base)
        moving = ca.fabs(brake) > 1e-12
        ratio = ca.if_else(moving, room / ca.if_else(moving, brake, 1.0), 1e30)
        scale = ca.mmin(ratio)
        scale = ca.if_else(scale < 1e29, scale, 0.0)  # no thruster moves: no braking term
        thrust = base + ca.fmax(scale, 0.0) * brake
        M, b = model.mass_matrix(h), model.bias(h, vc, ca.DM.zeros(3))
        a_hull = ca.solve(M[:6, :6], B @ thrust - b[:6])
        tau = (M[6:, :6] @ a_hull + b[6:] + self.hold.stiffness * (posture - h[6:6 + n])
               - self.hold.damping * h[12 + n:])
        u = ca.vertcat(thrust, ca.fmin(ca.fmax(tau, lo[nt:]), hi[nt:]))
        return ca.Function("braking_law", [h, posture, vc, lo, hi], [u])

    def compiled_rollout(self, steps: int, substeps: int, every_substep: bool) -> NumpyCall:
        """A rollout of `steps` intervals in one compiled call: (h0, posture, vc, lo, hi, dt) ->
        (states (ns, steps+1), inputs (nu, steps)), column-major. Each interval of dt [s] takes
        `substeps` RK4 steps; the policy acts once per interval and its input is held
        (`every_substep` False), or acts every substep and the interval's input is their mean."""
        key = (steps, substeps, every_substep)
        if key not in self._compiled:
            model, law = self.model, self.law()
            x, posture = ca.MX.sym("h", model.n_states), ca.MX.sym("posture", model.n_joints)
            vc = ca.MX.sym("vc", WATER)
            lo, hi, dt = ca.MX.sym("lo", model.n_inputs), ca.MX.sym("hi", model.n_inputs), ca.MX.sym("dt")
            Fw, Rw, ac = ca.DM.zeros(6), ca.DM.eye(3), ca.DM.zeros(3)
            h, u_sum, u = x, 0, law(x, posture, vc, lo, hi)
            for _ in range(substeps):
                if every_substep:
                    u = law(h, posture, vc, lo, hi)
                h = model.rk4(h, u, Fw, Rw, vc, ac, dt / substeps)
                u_sum = u_sum + u
            interval = ca.Function("interval", [x, posture, vc, lo, hi, dt], [h, u_sum / substeps])
            acc = interval.mapaccum("acc", steps, [0], [0])
            args = [ca.MX.sym(a.name(), a.sparsity()) for a in (x, posture, vc, lo, hi, dt)]
            hs, us = acc(args[0], *(ca.repmat(a, 1, steps) for a in args[1:]))
            f = ca.Function(f"rollout{steps}x{substeps}{'e' if every_substep else 'h'}", args,
                            [ca.horzcat(args[0], hs), us])
            name = f"{f.name()}_{model.params.name}_{model.params.arm.name}"
            self._compiled[key] = NumpyCall(compiled([f], name)[f.name()])
        return self._compiled[key]

    def rollout(self, h0: np.ndarray, posture: np.ndarray, dt: float, steps: int, substeps: int = 4,
                current: np.ndarray | None = None, every_substep: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """States (steps+1, ns) and inputs (steps, nu) of `compiled_rollout` from h0."""
        model = self.model
        hs, us = self.compiled_rollout(steps, substeps, every_substep)(
            h0, posture, water(current), self._lo, self._hi, np.array([dt], float))
        return (hs.reshape(steps + 1, model.n_states).copy(), us.reshape(steps, model.n_inputs).copy())

    def __call__(self, h: np.ndarray, posture: np.ndarray, current: np.ndarray | None = None) -> np.ndarray:
        model, n, nt = self.model, self.model.n_joints, self.model.params.n_thrusters
        vc = water(current)
        v, w = h[6 + n:9 + n], h[9 + n:12 + n]
        hold = np.concatenate([np.zeros(3), -ATTITUDE_STIFFNESS * np.array([h[3], h[4], 0.0]) - ATTITUDE_DAMPING * w])
        lo_t, hi_t = self._thrust_limit[:, 0], self._thrust_limit[:, 1]
        base = np.clip(self._pinv @ hold, lo_t, hi_t)
        brake = self._pinv @ np.concatenate([-v, np.zeros(3)])
        room = np.where(brake > 0, hi_t - base, lo_t - base)
        moving = np.abs(brake) > 1e-12
        scale = np.min(room[moving] / brake[moving]) if np.any(moving) else 0.0
        thrust = base + max(scale, 0.0) * brake
        M, b = model.mass_and_bias(h, vc)
        a_hull = np.linalg.solve(M[:6, :6], self._B @ thrust - b[:6])
        tau = (M[6:, :6] @ a_hull + b[6:] + self.hold.stiffness * (posture - h[6:6 + n])
               - self.hold.damping * h[12 + n:])
        return np.concatenate([thrust, np.clip(tau, self._lo[nt:], self._hi[nt:])])


def simulate(model: UVMSModel, h0: np.ndarray, us: np.ndarray, dt: float, substeps: int = 4,
             current: np.ndarray | None = None) -> np.ndarray:
    """States (N+1, ns) of inputs us (N, nu), each held over an interval of dt [s], integrated by the
    model's RK4 in `substeps` (the Final Algorithm's recomputed trajectory)."""
    hs = [np.asarray(h0, float)]
    for u in us:
        hs.append(model.held_steps(hs[-1], u, dt, substeps, vc=current))
    return np.array(hs)


class ReachPosture:
    """Joint angles [rad] that bring the end-effector tip furthest towards a plane for a given hull
    pose: min n.x_ee(q) over the joint range (+1e-3 |q - q_now|^2 to make it unique). The problem
    has local minima (from a stowed arm on a pitched hull the solver folds the arm further instead of
    stretching it out), so it starts from the current, the home and the straight-out posture and
    keeps the best."""

    def __init__(self, model: UVMSModel, plane: Plane):
        n = model.n_joints
        q, pose, q_now = ca.SX.sym("q", n), ca.SX.sym("pose", 6), ca.SX.sym("q_now", n)
        h = ca.vertcat(pose, q, ca.SX.zeros(model.n_speeds))
        reach = ca.dot(ca.DM(plane.normal), model.ee_pose(h)[0])
        self._solver = ca.nlpsol("reach", "ipopt", {"x": q, "p": ca.vertcat(pose, q_now),
                                                    "f": reach + 1e-3 * ca.sumsqr(q - q_now)},
                                 {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes", "max_iter": 100}})
        self._lo = np.array([lk.joint_range[0] for lk in model.params.arm.links])
        self._hi = np.array([lk.joint_range[1] for lk in model.params.arm.links])
        self._starts = (model.params.arm.home, np.zeros(n))
        self.n = n

    def __call__(self, h: np.ndarray) -> np.ndarray:
        q_now = h[6:6 + self.n]
        p = np.concatenate([h[:6], q_now])
        best = None
        for q0 in (q_now, *self._starts):
            r = self._solver(x0=np.clip(q0, self._lo, self._hi), p=p, lbx=self._lo, ubx=self._hi)
            if best is None or float(r["f"]) < float(best["f"]):
                best = r
        return np.asarray(best["x"]).ravel()
