"""Pieces shared by the three modes' OCPs: the implicit-midpoint dynamics constraint, the obstacle
frame, the clearance constraints and the solver's status.

Every mode transcribes the dynamics (paper eq. DynConstraints) by the implicit midpoint rule in
inverse-dynamics form (see controller.mode1): with h_m = (h_k + h_k+1)/2,
eta_k+1 = eta_k + dt eta_dot(h_m), nu_k+1 = nu_k + dt a_k and M(q_m) a_k = Q(h_m, u_k, F_k).
"""

from __future__ import annotations

from collections.abc import Sequence
from enum import Enum

import casadi as ca
import numpy as np

from controller.kinematics import euler_rates
from controller.model import UVMSModel
from uvms.scene import Plane


class SolverStatus(Enum):
    """Outcome of one OCP solve. FEASIBLE: the solver stopped at its iteration cap on an iterate
    that satisfies every constraint (violation below FEASIBLE_VIOLATION): a usable, suboptimal
    plan. REAL_TIME: the SQP's real-time iteration (controller.sqp) stopped at its iteration
    budget after a successful QP: the plan satisfies the constraints linearized at the warm start,
    not yet the nonlinear ones (its violation is in the result): usable, as in RTI schemes.
    STOPPED: IPOPT stopped at an iterate that the caller's test accepted (controller.iterate_stop);
    that test, not the iterate's constraint violation, says what the iterate is good for."""

    SUCCESS = "success"
    FEASIBLE = "feasible, not optimal"
    REAL_TIME = "real-time iterate"
    STOPPED = "stopped by the caller's test"
    MAX_ITER = "max_iter"
    INFEASIBLE = "infeasible"
    FAILED = "failed"

    @property
    def usable(self) -> bool:
        return self in (SolverStatus.SUCCESS, SolverStatus.FEASIBLE, SolverStatus.REAL_TIME,
                        SolverStatus.STOPPED)


FEASIBLE_VIOLATION = 1e-5  # largest constraint violation (m, N, N m) of a usable iterate at the iteration cap

_IPOPT = {"Solve_Succeeded": SolverStatus.SUCCESS, "Solved_To_Acceptable_Level": SolverStatus.SUCCESS,
          "Maximum_Iterations_Exceeded": SolverStatus.MAX_ITER, "Maximum_WallTime_Exceeded": SolverStatus.MAX_ITER,
          "Maximum_CpuTime_Exceeded": SolverStatus.MAX_ITER, "Infeasible_Problem_Detected": SolverStatus.INFEASIBLE}


def ipopt_status(stats: dict) -> SolverStatus:
    """The status of a CasADi IPOPT solve from its stats()."""
    status = _IPOPT.get(stats["return_status"], SolverStatus.FAILED)
    inf_pr = stats.get("iterations", {}).get("inf_pr", [np.inf])
    if status is SolverStatus.MAX_ITER and inf_pr and inf_pr[-1] < FEASIBLE_VIOLATION:
        return SolverStatus.FEASIBLE
    return status


def midpoint_residual(model: UVMSModel, h: ca.SX, u: ca.SX, a: ca.SX, h1: ca.SX, dt: ca.SX, vc: ca.SX,
                      Fw: ca.SX | None = None, Rw: ca.DM | None = None) -> ca.SX:
    """The dynamics residual (n_states + n_speeds) of one interval of length dt [s]; zero on the
    model's trajectory. Fw (6, obstacle frame Rw) is the end-effector contact wrench on the UVMS."""
    n, nv = model.n_joints, model.n_speeds
    hm = (h + h1) / 2
    Fw = ca.SX.zeros(6) if Fw is None else Fw
    Rw = ca.DM.eye(3) if Rw is None else Rw
    Q = sum(model.generalized_forces(hm, u, Fw, Rw, vc, ca.DM.zeros(3)))
    R = model.attitude(hm)
    eta_dot = ca.vertcat(R @ hm[6 + n:9 + n], euler_rates(hm[3:6], hm[9 + n:12 + n]), hm[12 + n:])
    return ca.vertcat(h1[:nv] - h[:nv] - dt * eta_dot, h1[nv:] - h[nv:] - dt * a, model.mass_matrix(hm) @ a - Q)


def obstacle_frame(normal: Sequence[float]) -> np.ndarray:
    """R_w (obstacle frame -> world): x along the plane's normal (into the water), y and z tangent."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    helper = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    t1 = np.cross(helper, n)
    t1 /= np.linalg.norm(t1)
    return np.column_stack([n, t1, np.cross(n, t1)])


def clearances(model: UVMSModel, h: ca.SX, planes: Sequence[Plane], contact: int | None = None) -> ca.SX:
    """Signed clearances [m] that must stay >= the margin: every body's superellipsoid and the
    end-effector tip (its sphere) to every plane. Against the `contact` plane (Modes II and III)
    the end-effector is allowed to touch, so its tip and the last link (whose box-like end reaches a
    plane before the tip once the arm is over 40 deg off the normal) are left out there."""
    tip = model.params.arm.tip_radius
    x_ee = model.ee_pose(h)[0]
    out = []
    for i, pl in enumerate(planes):
        d = model.distances(h, ca.DM(pl.normal), pl.offset)
        if model.n_joints and i == contact:
            out.append(d[:-1])
            continue
        out.append(d)
        if model.n_joints:
            out.append(ca.dot(ca.DM(pl.normal), x_ee) + pl.offset - tip)
    return ca.vertcat(*out) if out else ca.SX.zeros(0)


def contact_rows(model: UVMSModel, planes: Sequence[Plane], contact: int) -> np.ndarray:
    """Indices, within `clearances(model, h, planes, contact)`, of the rows against the contact plane
    (every body but the last link; the hull alone without an arm)."""
    per_plane = 1 + model.n_joints + (model.n_joints > 0)  # bodies, and the tip with an arm
    return np.arange(contact * per_plane, contact * per_plane + max(model.n_joints, 1))


def tip_gap(model: UVMSModel, h: ca.SX, plane: Plane) -> ca.SX:
    """Distance [m] from the end-effector tip's sphere to the plane (paper eq. EE_Wall_Dist_Constraint
    minus the tip radius): zero in contact."""
    return ca.dot(ca.DM(plane.normal), model.ee_pose(h)[0]) + plane.offset - model.params.arm.tip_radius


def smooth_norm(v: ca.SX, eps: float) -> ca.SX:
    """sqrt(|v|^2 + eps^2): |v| made differentiable at 0 (over-estimates by at most eps)."""
    return ca.sqrt(ca.dot(v, v) + eps * eps)


def smooth_relu(x: ca.SX, eps: float) -> ca.SX:
    """max(x, 0) smoothed: (x + sqrt(x^2 + eps^2)) / 2, within eps/2 of it."""
    return (x + ca.sqrt(x * x + eps * eps)) / 2
