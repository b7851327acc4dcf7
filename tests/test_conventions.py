"""Frame conversions against independent oracles: scipy's rotations and MuJoCo's own kinematics."""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from uvms.conventions import (
    euler_zyx_to_matrix,
    euler_zyx_to_quat_wxyz,
    matrix_to_euler_zyx,
    mujoco_to_state,
    quat_wxyz_to_matrix,
    quat_wxyz_to_xyzw,
    state_to_mujoco,
)
from uvms_mj.plant import Plant

RNG = np.random.default_rng(7)


def random_euler(n: int) -> np.ndarray:
    """Euler angles away from the theta = +-90 deg singularity."""
    return np.column_stack([RNG.uniform(-np.pi, np.pi, n), RNG.uniform(-1.4, 1.4, n),
                            RNG.uniform(-np.pi, np.pi, n)])


def test_euler_zyx_matches_scipy_intrinsic_zyx() -> None:
    for phi, theta, psi in random_euler(200):
        ref = Rotation.from_euler("ZYX", [psi, theta, phi])
        np.testing.assert_allclose(euler_zyx_to_matrix(phi, theta, psi), ref.as_matrix(), atol=1e-12)
        q = euler_zyx_to_quat_wxyz(phi, theta, psi)
        xyzw = ref.as_quat(canonical=True)
        np.testing.assert_allclose(quat_wxyz_to_xyzw(q), xyzw, atol=1e-12)
        np.testing.assert_allclose(quat_wxyz_to_matrix(q), ref.as_matrix(), atol=1e-12)
        np.testing.assert_allclose(matrix_to_euler_zyx(ref.as_matrix()), [phi, theta, psi], atol=1e-9)


def test_gimbal_lock_gives_a_valid_rotation() -> None:
    """At theta = 90 deg only psi - phi is defined: the angles returned reproduce the matrix."""
    R = euler_zyx_to_matrix(0.3, np.pi / 2, 1.1)
    np.testing.assert_allclose(euler_zyx_to_matrix(*matrix_to_euler_zyx(R)), R, atol=1e-9)


def test_state_round_trip_and_mujoco_body_velocity(params, open_water) -> None:
    """h -> (qpos, qvel) -> h is the identity, and MuJoCo's own body-frame velocity of the hull
    (mj_objectVelocity, local frame) equals h's body-frame v and omega."""
    plant = Plant(params, open_water)
    nj = params.n_joints
    hull = plant.model.body("hull").id
    vel6 = np.zeros(6)
    for phi, theta, psi in random_euler(50):
        h = np.concatenate([RNG.normal(size=3), [phi, theta, psi], params.arm.home + RNG.normal(0, 0.1, nj),
                            RNG.normal(size=6), RNG.normal(size=nj)])
        qpos, qvel = state_to_mujoco(h, nj)
        np.testing.assert_allclose(mujoco_to_state(qpos, qvel, nj), h, atol=1e-10)
        plant.set_state(h)
        mujoco.mj_objectVelocity(plant.model, plant.data, mujoco.mjtObj.mjOBJ_XBODY, hull, vel6, 1)
        np.testing.assert_allclose(vel6[3:], h[6 + nj:9 + nj], atol=1e-10)  # linear, body frame
        np.testing.assert_allclose(vel6[:3], h[9 + nj:12 + nj], atol=1e-10)  # angular, body frame
        np.testing.assert_allclose(plant.state(), h, atol=1e-10)
