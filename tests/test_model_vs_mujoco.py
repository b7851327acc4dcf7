"""The paper's model against MuJoCo's own dynamics (the plant with its fluid off): open-loop
trajectories, the mass matrix and bias with buoyancy (and added mass) on, and the contact-wrench
mapping."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from oracles.rigid_body import free_joint_map, free_joint_map_rate
from scipy.spatial.transform import Rotation

from controller.model import ModelOptions, UVMSModel
from controller.model import water as still_water
from uvms import load_params
from uvms.conventions import euler_zyx_to_matrix
from uvms_mj.build import COB_INERTIA, EE_SITE, HULL, BuildOptions
from uvms_mj.plant import Plant, PlantSettings
from validation.model_gap import RIGID_MODEL, RIGID_PLANT, open_loop_gap

TOL_M = 1e-10  # kg, kg m, kg m^2: per entry of M(q)
TOL_B = 1e-10  # relative to the largest entry of b


@pytest.mark.parametrize("added_mass", [False, True], ids=["rigid", "added mass"])
@pytest.mark.parametrize("arm", ["alpha3", "alpha4", "alpha6"])
def test_mass_matrix_and_bias_agree_with_buoyancy_on(scene, arm, added_mass) -> None:
    """30 random states per arm (any attitude, joints in range, random speeds), buoyancy and gravity
    on, fluid, joint friction and limits off: MuJoCo's mass matrix (mj_fullM of the plant's data,
    the added mass included when on), mapped to the paper's speeds (M = T^T M_mj T), equals the
    model's M(q) to 1e-10 per entry; with the added mass off, the bias T^T (M_mj Tdot nu +
    qfrc_bias - qfrc_passive) (gravity, Coriolis and buoyancy: MuJoCo's gravcomp at the centres of
    buoyancy is passive) equals the model's to 1e-10 of its largest entry. Both are exact in double
    precision (measured ~1e-14). With the added mass on, the model's bias holds the added mass's
    velocity terms, which are MuJoCo's fluid model's in the plant (off here): not compared.

    Sensitivity: each centre-of-buoyancy body has inertia COB_INERTIA = 1e-9 kg m^2; counted on top
    of its parent's (the composite's inertia twice), it raised every rotational entry by at least
    1e-9 (10x the tolerance) and the hull's by 5e-9 (measured)."""
    p = load_params(arm=arm)
    water = scene.with_planes(())
    plant = Plant(p, water, PlantSettings(build=BuildOptions(fluid=False, joint_damping=False, joint_limits=False,
                                                             added_mass=added_mass)))
    model = UVMSModel(p, water.water, ModelOptions(drag=False, added_mass=added_mass))
    m, d, n = plant.model, plant.data, p.n_joints
    rng = np.random.default_rng(n)
    assert COB_INERTIA >= 5 * TOL_M
    for _ in range(30):
        h = np.zeros(p.n_states)
        h[:3] = rng.normal(size=3)
        h[3:6] = [rng.uniform(-np.pi, np.pi), rng.uniform(-1.3, 1.3), rng.uniform(-np.pi, np.pi)]
        lo, hi = np.array([lk.joint_range for lk in p.arm.links]).T
        h[6:6 + n], h[6 + n:] = rng.uniform(lo, hi), rng.normal(0, 1.0, 6 + n)
        plant.set_state(h)
        M_mj = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M_mj)
        R = d.xmat[m.body(HULL).id].reshape(3, 3)
        T = free_joint_map(R, n)
        np.testing.assert_allclose(T.T @ M_mj @ T, np.asarray(model.mass_matrix(h)), rtol=0, atol=TOL_M)
        if not added_mass:
            b = T.T @ (M_mj @ free_joint_map_rate(R, h[6 + n:]) + d.qfrc_bias - d.qfrc_passive)
            b_model = np.asarray(model.bias(h, still_water(), np.zeros(3))).ravel()
            np.testing.assert_allclose(b, b_model, rtol=0, atol=TOL_B * np.abs(b_model).max())


@pytest.mark.slow
@pytest.mark.parametrize("arm", ["alpha3", "alpha4", "alpha6"])
def test_open_loop_trajectories_agree_without_fluid(scene, arm) -> None:
    """Rigid body, gravity and buoyancy on both sides (no fluid, added mass, joint friction or
    limits), the same thrust and free arm for 2 s: the model (RK4, 2.5 ms) and MuJoCo agree to
    below 1 mm and 0.05 deg, and the gap halves when MuJoCo's timestep halves (0.5 -> 0.25 ms;
    ratio 2 +- 10%): what remains is the first-order error of MuJoCo's implicitfast integrator,
    not a difference of dynamics."""
    p = load_params(arm=arm)
    gaps = [open_loop_gap(p, scene, (2.0,), RIGID_MODEL, dataclasses.replace(RIGID_PLANT, timestep=ts))[0]
            for ts in (0.0005, 0.00025)]
    assert gaps[1].position < 1e-3 and gaps[1].attitude < 0.05
    assert gaps[0].position / gaps[1].position == pytest.approx(2.0, rel=0.1)


@pytest.mark.slow
def test_joint_damping_matches_the_plants_gearbox_friction(scene, params) -> None:
    """ModelOptions(joint_damping=True) against MuJoCo's joint damping from the same parameter file,
    rigid bodies otherwise (as the test above), the same inputs for 2 s: the trajectories agree as
    closely as without damping (below 1 mm and 0.05 deg, MuJoCo at 0.25 ms), while the model without
    the term misses the damped plant's joints by more than a degree (the check can fail)."""
    plant = dataclasses.replace(RIGID_PLANT, joint_damping=True)
    damped = open_loop_gap(params, scene, (2.0,), dataclasses.replace(RIGID_MODEL, joint_damping=True), plant)[0]
    undamped = open_loop_gap(params, scene, (2.0,), RIGID_MODEL, plant)[0]
    assert damped.position < 1e-3 and damped.attitude < 0.05 and damped.joints < 0.05
    assert undamped.joints > 1.0


def _random_state(params, rng: np.random.Generator) -> np.ndarray:
    """A state at rest: position ~ N(0, 1) m, Euler angles ~ U(-1, 1) rad, joints home +- 0.5 rad."""
    h, n = np.zeros(params.n_states), params.n_joints
    h[:3], h[3:6] = rng.normal(size=3), rng.uniform(-1, 1, 3)
    h[6:6 + n] = params.arm.home + rng.uniform(-0.5, 0.5, n)
    return h


def test_contact_wrench_maps_like_mj_applyFT(params, scene) -> None:
    """A wrench F^w in a random obstacle frame R_w at the end-effector (paper eq. F_contact):
    the model's generalized force equals MuJoCo's mj_applyFT of the world wrench at the EE site
    on the last link, mapped to the paper's speeds (qfrc_paper = T^T qfrc_mujoco, T =
    blockdiag(R, I)), to 1e-10."""
    model = UVMSModel(params, scene.water)
    plant = Plant(params, scene.with_planes(()), PlantSettings(build=RIGID_PLANT))
    m, d = plant.model, plant.data
    rng = np.random.default_rng(4)
    for _ in range(20):
        h = _random_state(params, rng)
        plant.set_state(h)
        Rw = Rotation.random(random_state=rng).as_matrix()
        Fw = rng.normal(0, 10, 6)
        qfrc = np.zeros(m.nv)
        last = m.body(params.arm.links[-1].name).id
        mujoco.mj_applyFT(m, d, Rw @ Fw[:3], Rw @ Fw[3:], d.site_xpos[m.site(EE_SITE).id], last, qfrc)
        T = np.eye(m.nv)
        T[:3, :3] = euler_zyx_to_matrix(*h[3:6])
        out = model.generalized_forces(h, np.zeros(params.n_inputs), Fw, Rw, still_water(), np.zeros(3))
        np.testing.assert_allclose(np.asarray(out[-1]).ravel(), T.T @ qfrc, atol=1e-10)


def test_strut_arm_is_the_moment_arm_mujoco_measures(params, scene) -> None:
    """controller.mode3.strut_arm, Mode III's strut term: on 20 random states its norm equals the
    distance from the hull body's centre of mass to the line through the end-effector site along the
    wall's normal, read from MuJoCo's own kinematics (d.xipos, d.site_xpos), to 1e-5 m: the tip agrees
    to rounding, but MuJoCo's hull body puts its centre of mass 1.1e-6 m from the parameter file's
    (measured at rest; the plant composes the hull's inertia itself)."""
    import casadi as ca

    from controller.mode3 import strut_arm

    model = UVMSModel(params, scene.water)
    plant = Plant(params, scene.with_planes(()), PlantSettings(build=RIGID_PLANT))
    m, d = plant.model, plant.data
    wall = scene.planes[0]
    h_sym = ca.SX.sym("h", params.n_states)
    arm = ca.Function("arm", [h_sym], [strut_arm(model, h_sym, wall)])
    rng = np.random.default_rng(5)
    for _ in range(20):
        h = _random_state(params, rng)
        plant.set_state(h)
        r = d.site_xpos[m.site(EE_SITE).id] - d.xipos[m.body(HULL).id]
        expected = np.linalg.norm(r - np.dot(r, wall.normal) * np.asarray(wall.normal))
        assert abs(float(np.linalg.norm(np.asarray(arm(h)).ravel())) - expected) < 1e-5
