"""Frames and conversions, written once (numpy only).

- World frame z up. Body frame x forward, y left, z up (FLU). FRD/NED literature vectors map to
  FLU by `FRD_TO_FLU` (y and z change sign).
- Orientation: ZYX Euler angles (phi, theta, psi) with R = Rz(psi) Ry(theta) Rx(phi), rotating
  body vectors into the world frame.
- The paper's state h = [x y z phi theta psi q_m | v omega qdot_m]: world position, Euler
  angles, body-frame linear and angular velocity, joint angles and rates.
- MuJoCo's free joint: qpos = [x y z qw qx qy qz q_m] (wxyz quaternion), qvel = [world linear
  velocity, body angular velocity, qdot_m].
- Rerun quaternions are xyzw.
"""

from __future__ import annotations

import numpy as np

FRD_TO_FLU = np.diag([1.0, -1.0, -1.0])


def euler_zyx_to_matrix(phi: float, theta: float, psi: float) -> np.ndarray:
    """Rotation matrix R = Rz(psi) Ry(theta) Rx(phi) (body to world)."""
    cf, sf = np.cos(phi), np.sin(phi)
    ct, st = np.cos(theta), np.sin(theta)
    cp, sp = np.cos(psi), np.sin(psi)
    return np.array([
        [cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf],
        [sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf],
        [-st, ct * sf, ct * cf],
    ])


def matrix_to_euler_zyx(R: np.ndarray) -> np.ndarray:
    """ZYX Euler angles (phi, theta, psi) of R; at theta = +-90 deg, phi is set to 0."""
    st = -R[2, 0]
    theta = np.arcsin(np.clip(st, -1.0, 1.0))
    if abs(st) < 1.0 - 1e-12:
        phi = np.arctan2(R[2, 1], R[2, 2])
        psi = np.arctan2(R[1, 0], R[0, 0])
    else:  # gimbal lock: only psi -+ phi is defined
        phi = 0.0
        psi = np.arctan2(-R[0, 1], R[1, 1])
    return np.array([phi, theta, psi])


def quat_wxyz_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def euler_zyx_to_quat_wxyz(phi: float, theta: float, psi: float) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of Rz(psi) Ry(theta) Rx(phi), with w >= 0."""
    cf, sf = np.cos(phi / 2), np.sin(phi / 2)
    ct, st = np.cos(theta / 2), np.sin(theta / 2)
    cp, sp = np.cos(psi / 2), np.sin(psi / 2)
    q = np.array([
        cp * ct * cf + sp * st * sf,
        cp * ct * sf - sp * st * cf,
        cp * st * cf + sp * ct * sf,
        sp * ct * cf - cp * st * sf,
    ])
    return q if q[0] >= 0 else -q


def quat_wxyz_to_xyzw(q: np.ndarray) -> np.ndarray:
    """MuJoCo (w, x, y, z) to Rerun/scipy (x, y, z, w)."""
    return np.asarray(q)[..., [1, 2, 3, 0]]


def split_state(h: np.ndarray, n_joints: int) -> tuple[np.ndarray, ...]:
    """h -> (position, euler, q_m, v_body, omega_body, qdot_m)."""
    n = 6 + n_joints
    return h[0:3], h[3:6], h[6:n], h[n:n + 3], h[n + 3:n + 6], h[n + 6:]


def state_to_mujoco(h: np.ndarray, n_joints: int) -> tuple[np.ndarray, np.ndarray]:
    """Paper state h -> MuJoCo (qpos, qvel) of a free-floating base plus hinge joints."""
    pos, eul, qm, v, w, qd = split_state(np.asarray(h, dtype=float), n_joints)
    R = euler_zyx_to_matrix(*eul)
    qpos = np.concatenate([pos, euler_zyx_to_quat_wxyz(*eul), qm])
    qvel = np.concatenate([R @ v, w, qd])
    return qpos, qvel


def mujoco_to_state(qpos: np.ndarray, qvel: np.ndarray, n_joints: int) -> np.ndarray:
    """MuJoCo (qpos, qvel) of a free-floating base plus hinge joints -> paper state h."""
    R = quat_wxyz_to_matrix(qpos[3:7])
    return np.concatenate([
        qpos[0:3], matrix_to_euler_zyx(R), qpos[7:7 + n_joints],
        R.T @ qvel[0:3], qvel[3:6], qvel[6:6 + n_joints],
    ])
