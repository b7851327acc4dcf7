"""The paper's model (Kane's method, CasADi) against two independent rigid-body oracles, Pinocchio
and MuJoCo (tests/oracles), with buoyancy, fluid and added mass off on all sides."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from helpers import random_states
from oracles.rigid_body import MujocoOracle, PinocchioOracle

from controller.model import ModelOptions, UVMSModel, water
from controller.transcription import obstacle_frame
from uvms import load_params

RIGID = ModelOptions(buoyancy=False, added_mass=False, drag=False)
ARMS = ["alpha3", "alpha4", "alpha6"]


@pytest.fixture(scope="module", params=ARMS)
def setup(request, scene):
    p = load_params(arm=request.param)
    model = UVMSModel(p, scene.water, RIGID)
    return p, model, (PinocchioOracle(p, scene.water.gravity), MujocoOracle(p, scene, scene.water.gravity))


def test_mass_matrix_and_bias_equal_both_oracles(setup) -> None:
    """100 random states per arm: M(q) and the bias b(q, nu) = -(Coriolis + gravity) equal
    Pinocchio's (crba, rnea) and MuJoCo's (mj_fullM, qfrc_bias, mapped to the paper's speeds) to
    1e-8 relative (the three agree to ~1e-14: 1e-8 leaves room for rounding and catches any
    modelling difference). So does the compiled
    `mass_and_bias` (the braking rollout's), which must also equal the SX functions to the bit (the
    same operations in C)."""
    p, model, oracles = setup
    for h in random_states(p, 100, seed=p.n_joints):
        M = np.asarray(model.mass_matrix(h))
        b = np.asarray(model.bias(h, water(), np.zeros(3))).ravel()
        M_c, b_c = model.mass_and_bias(h)
        assert np.array_equal(M_c, M) and np.array_equal(b_c, b)
        for oracle in oracles:
            M_ref, b_ref = oracle.mass_matrix(h), oracle.bias(h)
            assert np.linalg.norm(M - M_ref) <= 1e-8 * np.linalg.norm(M_ref), type(oracle).__name__
            assert np.linalg.norm(b - b_ref) <= 1e-8 * np.linalg.norm(b_ref), type(oracle).__name__


def test_forward_kinematics_and_jacobian_equal_both_oracles(setup) -> None:
    """Link frames, end-effector pose (paper eq. IN2EE) and the geometric Jacobian J_v (eq. Jv)
    equal Pinocchio's and MuJoCo's to 1e-10 (m, -, m/s per unit speed)."""
    p, model, oracles = setup
    n = p.n_joints
    for h in random_states(p, 50, seed=100 + n):
        links = [np.asarray(a) for a in model.link_poses(h)]
        x_ee, R_ee = (np.asarray(a) for a in model.ee_pose(h))
        Jv = np.asarray(model.jacobian_ee(h))
        for oracle in oracles:
            poses = oracle.poses(h)
            for k in range(n):
                np.testing.assert_allclose(links[k].ravel(), poses.positions[1 + k], atol=1e-10)
                np.testing.assert_allclose(links[n + k], poses.rotations[1 + k], atol=1e-10)
            np.testing.assert_allclose(x_ee.ravel(), poses.ee_position, atol=1e-10)
            np.testing.assert_allclose(R_ee, poses.ee_rotation, atol=1e-10)
            np.testing.assert_allclose(Jv, oracle.ee_jacobian(h), atol=1e-10)


def test_held_steps_are_the_steps_in_one_call(scene) -> None:
    """UVMSModel.held_steps (the rollouts' interval: 4 RK4 substeps, input held, one compiled call)
    against 4 calls of UVMSModel.step with the same input, a current and, on every other state, a
    contact force in a tilted wall's frame: equal to the bit (the same C code for each substep), on
    20 random states and inputs within the bounds."""
    p = load_params()
    model = UVMSModel(p, scene.water)
    rng = np.random.default_rng(4)
    lo, hi = p.input_bounds()
    Rw = obstacle_frame(np.array([-0.8, 0.6, 0.0]))
    for i, h in enumerate(random_states(p, 20, seed=4)):
        u, vc = rng.uniform(lo, hi), rng.normal(0, 0.2, 3)
        Fw = np.concatenate([rng.uniform(0, 100, 1), rng.normal(0, 20, 2), np.zeros(3)]) if i % 2 else None
        x = h
        for _ in range(4):
            x = model.step(x, u, 0.1 / 4, Fw=Fw, Rw=Rw, vc=vc)
        assert np.array_equal(model.held_steps(h, u, 0.1, 4, Fw=Fw, Rw=Rw, vc=vc), x)


def test_pitched_attitude_angles_are_the_same_physics_and_regular_at_90_deg(scene) -> None:
    """ModelOptions.pitch_offset = pi/2 (Mode III's angles past `regular_pitch`): (1) on 30 random
    states, re-expressed in its angles, M and the bias equal Pinocchio's for the world's angles to
    1e-8 relative (as the world model's, above); (2) at 89.99 deg of pitch its Euler-angle rates move
    the attitude as the body rates do, R(h + e hdot) = R(h)(I + e [w]x) + O(e^2) (closed form,
    e = 1e-6, so 1e-9 bounds the second-order rest), while the world's angles, their rate map held
    at |cos(pitch)| >= 1e-3 there, miss by over 1e-7."""
    p = load_params()
    world, pitched = UVMSModel(p, scene.water, RIGID), UVMSModel(p, scene.water, replace(RIGID, pitch_offset=np.pi / 2))
    oracle = PinocchioOracle(p, scene.water.gravity)
    for h in random_states(p, 30, seed=7):
        hp = world.angles_to_options(h, pitched)
        np.testing.assert_allclose(np.asarray(pitched.rotation(hp)), np.asarray(world.rotation(h)), atol=1e-12)
        M, M_ref = np.asarray(pitched.mass_matrix(hp)), oracle.mass_matrix(h)
        b, b_ref = np.asarray(pitched.bias(hp, water(), np.zeros(3))).ravel(), oracle.bias(h)
        assert np.linalg.norm(M - M_ref) <= 1e-8 * np.linalg.norm(M_ref)
        assert np.linalg.norm(b - b_ref) <= 1e-8 * np.linalg.norm(b_ref)
    n, e = p.n_joints, 1e-6
    h = random_states(p, 1, seed=8)[0]
    h[4] = np.radians(89.99)
    u = np.zeros(p.n_inputs)

    def miss(model: UVMSModel, x: np.ndarray) -> float:
        w = x[9 + n:12 + n]
        skew = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        R = np.asarray(model.rotation(x))
        return float(np.abs(np.asarray(model.rotation(x + e * model.hdot(x, u))) - R @ (np.eye(3) + e * skew)).max())

    assert miss(pitched, world.angles_to_options(h, pitched)) < 1e-9
    assert miss(world, h) > 1e-7
