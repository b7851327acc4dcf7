"""Two independent rigid-body oracles of the UVMS in the paper's coordinates: Pinocchio and MuJoCo.

Coordinates (the paper's, see `uvms.conventions`):

- state h = [x y z phi theta psi q_m | v omega qdot_m] (length 2 n, n = 6 + n_joints): world position
  of the hull origin [m], ZYX Euler angles [rad] with R = Rz(psi) Ry(theta) Rx(phi) (body to world),
  joint angles [rad] | BODY-frame linear velocity of the hull origin [m/s], BODY-frame angular
  velocity [rad/s], joint rates [rad/s];
- generalized speeds nu = [v, omega, qdot_m] (n,);
- dynamics M(q) nu_dot + b(q, nu) = tau, with tau = [body-frame force on the hull origin [N],
  body-frame moment about the hull origin [N m], joint torques [N m]] (the generalized force whose
  power is tau . nu). b holds gravity and the Coriolis/centrifugal terms.

Physics: rigid bodies only (no buoyancy, no fluid, no added mass), gravity g [m/s^2] along world -z,
and each joint's `rotor_inertia` [kg m^2] as a diagonal term of M on that joint's DOF (MuJoCo's and
Pinocchio's armature).

Kinematics (header of `assets/bluerov2_heavy_alpha.toml`): the hull frame is the body frame; joint 0
sits at `hull.arm_mount` in the hull frame, joint i > 0 at (links[i-1].length, 0, 0) in link i-1's
frame; at q = 0 every link frame is parallel to the hull frame; joint i turns link i about
`links[i].joint_axis` (link i's frame, equal to its parent's at q = 0); the end-effector point is
`arm.end_effector` in the last link's frame.

Mappings verified here and in tests/test_oracles_agree.py:

- Pinocchio's free flyer: q = [x y z qx qy qz qw, q_m] (xyzw quaternion of R), velocity = the base's
  LOCAL twist [R^T pdot, omega_body]: exactly nu, so no velocity map is needed.
- MuJoCo's free joint: qpos = [x y z qw qx qy qz, q_m], qvel = [pdot (world), omega_body, qdot_m]
  = T nu with T = blockdiag(R, I3, I_nj). Power tau_mj . qvel = tau . nu gives tau = T^T tau_mj;
  qacc = T nu_dot + Tdot nu with Tdot nu = [Rdot v; 0; 0] = [R (omega x v); 0; 0]; so
  M = T^T M_mj T and b = T^T (M_mj Tdot nu + qfrc_bias); the end-effector Jacobian J = J_mj T.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import mujoco
import numpy as np
import pinocchio as pin

from uvms.conventions import state_to_mujoco
from uvms.params import UVMSParams
from uvms.scene import Scene
from uvms_mj.build import EE_SITE, HULL, ROOT_JOINT, BuildOptions, compile_model

GRAVITY = 9.81  # m/s^2, default magnitude of gravity (along world -z)
EE_FRAME = "ee"  # name of the end-effector frame in the Pinocchio model


@dataclass(frozen=True)
class Poses:
    """World poses of the hull and link frames and of the end-effector point.

    positions: (1 + n_joints, 3) [m], origins of the hull frame then of link frames 0.. (link i's origin
    is joint i); rotations: (1 + n_joints, 3, 3), frame to world; ee_position: (3,) [m];
    ee_rotation: (3, 3), the last link's rotation.
    """

    positions: np.ndarray
    rotations: np.ndarray
    ee_position: np.ndarray
    ee_rotation: np.ndarray


class RigidBodyOracle(Protocol):
    """What both oracles offer, everything in the paper's coordinates (module docstring)."""

    n_joints: int

    def mass_matrix(self, h: np.ndarray) -> np.ndarray:
        """M(q): (n, n) [kg, kg m, kg m^2 blocks], symmetric, armature included."""
        ...

    def bias(self, h: np.ndarray) -> np.ndarray:
        """b(q, nu): (n,) [N, N m], gravity plus Coriolis/centrifugal (tau = M nu_dot + b)."""
        ...

    def poses(self, h: np.ndarray) -> Poses:
        """Forward kinematics of every link frame and of the end-effector point."""
        ...

    def ee_jacobian(self, h: np.ndarray) -> np.ndarray:
        """(6, n): [world linear velocity of the EE point [m/s]; world angular velocity of the last link
        [rad/s]] = J nu."""
        ...


def split_state(h: np.ndarray, n_joints: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """h -> (position [m] (3,), Euler angles [rad] (3,), q_m [rad] (n_joints,), nu (6 + n_joints,))."""
    h = np.asarray(h, dtype=float)
    n = 6 + n_joints
    if h.shape != (2 * n,):
        raise ValueError(f"state of shape {h.shape} is not allowed; allowed: ({2 * n},) for {n_joints} joints")
    return h[0:3], h[3:6], h[6:n], h[n:]


def free_joint_map(R: np.ndarray, n_joints: int) -> np.ndarray:
    """T (n, n) with MuJoCo's qvel = T nu: blockdiag(R, I3, I_nj) (R body to world)."""
    T = np.eye(6 + n_joints)
    T[0:3, 0:3] = R
    return T


def free_joint_map_rate(R: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """Tdot nu (n,): [R (omega x v) [m/s^2]; 0], because Rdot = R S(omega) and the other blocks are constant."""
    out = np.zeros(len(nu))
    out[0:3] = R @ np.cross(nu[3:6], nu[0:3])
    return out


# ---------------------------------------------------------------------------------------------
# Pinocchio


def _basis_joint(axis: np.ndarray) -> object | None:
    """RX/RY/RZ when `axis` is exactly +e_x, +e_y or +e_z, else None."""
    for k, joint in enumerate((pin.JointModelRX, pin.JointModelRY, pin.JointModelRZ)):
        if np.array_equal(axis, np.eye(3)[k]):
            return joint()
    return None


def build_pinocchio_model(params: UVMSParams, gravity: float = GRAVITY, aligned: bool = True) -> pin.Model:
    """A pinocchio.Model of the rigid UVMS: a free-flyer root (the hull) and one revolute joint per link.

    Args:
        params: the vehicle.
        gravity: magnitude g [m/s^2] of gravity along world -z.
        aligned: use JointModelRX/RY/RZ for axes that are exactly +x/+y/+z (otherwise and when False,
            JointModelRevoluteUnaligned).

    Joint k + 1 is link k's joint; its joint frame is link k's frame. Frames: one body frame per link
    (named after it), `hull`, and the operational frame `ee` at the end-effector point.
    """
    model = pin.Model()
    model.name = f"{params.name}_{params.arm.name}"
    model.gravity = pin.Motion(np.array([0.0, 0.0, -gravity]), np.zeros(3))
    h = params.hull
    root = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
    model.appendBodyToJoint(root, pin.Inertia(h.mass, np.asarray(h.com, float), np.asarray(h.inertia, float)),
                            pin.SE3.Identity())
    model.addFrame(pin.Frame(HULL, root, pin.SE3.Identity(), pin.FrameType.BODY))
    parent, offset = root, np.asarray(h.arm_mount, float)
    for lk in params.arm.links:
        axis = np.asarray(lk.joint_axis, float)
        jm = (_basis_joint(axis) if aligned else None) or pin.JointModelRevoluteUnaligned(axis)
        jid = model.addJoint(parent, jm, pin.SE3(np.eye(3), offset), f"{lk.name}_joint")
        model.appendBodyToJoint(jid, pin.Inertia(lk.mass, np.asarray(lk.com, float), np.diag(lk.inertia)),
                                pin.SE3.Identity())
        model.addFrame(pin.Frame(lk.name, jid, pin.SE3.Identity(), pin.FrameType.BODY))
        model.armature[model.idx_vs[jid]] = lk.rotor_inertia
        parent, offset = jid, np.array([lk.length, 0.0, 0.0])
    if params.arm.n_joints:
        model.addFrame(pin.Frame(EE_FRAME, parent, pin.SE3(np.eye(3), np.asarray(params.arm.end_effector, float)),
                                 pin.FrameType.OP_FRAME))
    return model


class PinocchioOracle:
    """Rigid-body dynamics and kinematics of the UVMS by Pinocchio, in the paper's coordinates.

    Pinocchio's free-flyer velocity is the base's local twist [R^T pdot, omega_body], i.e. exactly nu;
    its configuration carries the xyzw quaternion of R = Rz(psi) Ry(theta) Rx(phi) (built with
    pinocchio.rpy, not with uvms.conventions).
    """

    def __init__(self, params: UVMSParams, gravity: float = GRAVITY, aligned: bool = True) -> None:
        """params: the vehicle; gravity: g [m/s^2] along world -z; aligned: see build_pinocchio_model."""
        self.params = params
        self.n_joints = params.arm.n_joints
        self.model = build_pinocchio_model(params, gravity, aligned)
        self.data = self.model.createData()
        self.link_frames = [self.model.getFrameId(HULL)] + [self.model.getFrameId(lk.name)
                                                            for lk in params.arm.links]
        self.ee_frame = self.model.getFrameId(EE_FRAME) if self.n_joints else self.link_frames[0]
        assert self.model.nv == 6 + self.n_joints and self.model.nq == 7 + self.n_joints

    def configuration(self, h: np.ndarray) -> np.ndarray:
        """Pinocchio q (7 + n_joints,): [x y z [m], qx qy qz qw, q_m [rad]]."""
        pos, eul, qm, _ = split_state(h, self.n_joints)
        R = pin.rpy.rpyToMatrix(*eul)  # Rz(yaw) Ry(pitch) Rx(roll)
        return np.concatenate([pos, pin.Quaternion(R).coeffs(), qm])  # coeffs() is (x, y, z, w)

    def velocity(self, h: np.ndarray) -> np.ndarray:
        """Pinocchio v (6 + n_joints,) = nu = [v_body [m/s], omega_body [rad/s], qdot_m [rad/s]]."""
        return split_state(h, self.n_joints)[3].copy()

    def mass_matrix(self, h: np.ndarray) -> np.ndarray:
        """M(q) (n, n), CRBA with the lower triangle filled from the upper one; armature included."""
        M = pin.crba(self.model, self.data, self.configuration(h))
        return np.triu(M) + np.triu(M, 1).T

    def bias(self, h: np.ndarray) -> np.ndarray:
        """b(q, nu) (n,) [N, N m]: RNEA with zero acceleration (gravity + Coriolis/centrifugal)."""
        q, v = self.configuration(h), self.velocity(h)
        return pin.rnea(self.model, self.data, q, v, np.zeros(self.model.nv)).copy()

    def poses(self, h: np.ndarray) -> Poses:
        """World poses of the hull and link frames and of the EE point (see Poses)."""
        pin.framesForwardKinematics(self.model, self.data, self.configuration(h))
        frames = [self.data.oMf[f] for f in self.link_frames]
        ee = self.data.oMf[self.ee_frame]
        return Poses(positions=np.array([f.translation for f in frames]),
                     rotations=np.array([f.rotation for f in frames]),
                     ee_position=ee.translation.copy(), ee_rotation=ee.rotation.copy())

    def ee_jacobian(self, h: np.ndarray) -> np.ndarray:
        """(6, n): LOCAL_WORLD_ALIGNED Jacobian of the EE frame, i.e. [world velocity of the EE point;
        world angular velocity of the last link] per unit nu (Pinocchio v = nu)."""
        q = self.configuration(h)
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        return pin.getFrameJacobian(self.model, self.data, self.ee_frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED).copy()


# ---------------------------------------------------------------------------------------------
# MuJoCo


class MujocoOracle:
    """Rigid-body dynamics and kinematics of the project's own MuJoCo plant with fluid, buoyancy and
    added mass switched off (BuildOptions(fluid=False, buoyancy=False, added_mass=False)), mapped to
    the paper's coordinates (module docstring): M = T^T M_mj T, b = T^T (M_mj Tdot nu + qfrc_bias),
    J = J_mj T.

    qfrc_bias is MuJoCo's RNEA at zero acceleration (gravity + Coriolis/centrifugal); joint damping,
    limits and contacts are passive or constraint forces and do not enter it.
    """

    def __init__(self, params: UVMSParams, scene: Scene, gravity: float = GRAVITY) -> None:
        """params: the vehicle; scene: any scene (its obstacles and water do not enter M, b, FK, J);
        gravity: g [m/s^2] along world -z (overrides the scene's)."""
        self.params = params
        self.n_joints = params.arm.n_joints
        _, self.model = compile_model(params, scene, BuildOptions(fluid=False, buoyancy=False, added_mass=False))
        self.model.opt.gravity[:] = [0.0, 0.0, -gravity]
        self.data = mujoco.MjData(self.model)
        m = self.model
        root = m.joint(ROOT_JOINT)
        assert m.nv == 6 + self.n_joints and m.nq == 7 + self.n_joints
        assert root.qposadr[0] == 0 and root.dofadr[0] == 0
        for i, lk in enumerate(params.arm.links):  # hinge i sits at qpos[7 + i], qvel[6 + i]
            jnt = m.joint(f"{lk.name}_joint")
            assert jnt.qposadr[0] == 7 + i and jnt.dofadr[0] == 6 + i
        self.bodies = [m.body(HULL).id] + [m.body(lk.name).id for lk in params.arm.links]
        self.ee_site = m.site(EE_SITE).id if self.n_joints else -1

    def forward(self, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Set qpos, qvel from h (uvms.conventions.state_to_mujoco), run mj_forward; return (R, nu)."""
        qpos, qvel = state_to_mujoco(np.asarray(h, float), self.n_joints)
        self.data.qpos[:], self.data.qvel[:] = qpos, qvel
        self.data.qacc[:] = 0.0
        self.data.qfrc_applied[:] = 0.0
        self.data.ctrl[:] = 0.0
        mujoco.mj_forward(self.model, self.data)
        R = self.data.xmat[self.bodies[0]].reshape(3, 3).copy()
        return R, split_state(h, self.n_joints)[3]

    def mass_matrix_mujoco(self, h: np.ndarray) -> np.ndarray:
        """MuJoCo's own M_mj (n, n) in qvel coordinates (mj_fullM)."""
        self.forward(h)
        M = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, M)
        return M

    def mass_matrix(self, h: np.ndarray) -> np.ndarray:
        """M(q) (n, n) = T^T M_mj T."""
        M = self.mass_matrix_mujoco(h)
        T = free_joint_map(self.data.xmat[self.bodies[0]].reshape(3, 3), self.n_joints)
        return T.T @ M @ T

    def bias(self, h: np.ndarray) -> np.ndarray:
        """b(q, nu) (n,) [N, N m] = T^T (M_mj Tdot nu + qfrc_bias)."""
        M = self.mass_matrix_mujoco(h)
        R, nu = self.data.xmat[self.bodies[0]].reshape(3, 3).copy(), split_state(h, self.n_joints)[3]
        T = free_joint_map(R, self.n_joints)
        return T.T @ (M @ free_joint_map_rate(R, nu) + self.data.qfrc_bias)

    def poses(self, h: np.ndarray) -> Poses:
        """World poses of the hull and link bodies (data.xpos, xmat) and of the `ee` site."""
        self.forward(h)
        d = self.data
        ee_pos = d.site_xpos[self.ee_site].copy() if self.n_joints else d.xpos[self.bodies[0]].copy()
        return Poses(positions=d.xpos[self.bodies].copy(),
                     rotations=d.xmat[self.bodies].reshape(-1, 3, 3).copy(),
                     ee_position=ee_pos, ee_rotation=d.xmat[self.bodies[-1]].reshape(3, 3).copy())

    def ee_jacobian(self, h: np.ndarray) -> np.ndarray:
        """(6, n) = J_mj T, J_mj from mj_jac at the EE point on the last link body."""
        R, _ = self.forward(h)
        jacp, jacr = np.zeros((3, self.model.nv)), np.zeros((3, self.model.nv))
        point = self.data.site_xpos[self.ee_site] if self.n_joints else self.data.xpos[self.bodies[0]]
        mujoco.mj_jac(self.model, self.data, jacp, jacr, point, self.bodies[-1])
        return np.vstack([jacp, jacr]) @ free_joint_map(R, self.n_joints)
