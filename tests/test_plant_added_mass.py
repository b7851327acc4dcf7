"""Added mass: the plant's effective inertia equals m + M_A on all six hull axes, and stays stable."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from helpers import hull_mass_matrix, neutral, with_hull, zero_input

from uvms_mj.build import BuildOptions
from uvms_mj.plant import Plant, PlantSettings

NO_GRAVITY = PlantSettings(build=BuildOptions(gravity=False))
AXES = ["surge", "sway", "heave", "roll", "pitch", "yaw"]


def step_response(p, scene, axis: int, amplitude: float, settings=NO_GRAVITY, steps: int = 1):
    """Body-frame velocity after `steps` physics steps of a body-axis step wrench, from rest."""
    plant = Plant(p, scene, settings)
    w_body = np.zeros(6)
    w_body[axis] = amplitude
    plant.set_external_wrench("hull", w_body)  # hull starts level: body axes = world axes
    dt = plant.model.opt.timestep
    h = plant.step(zero_input(p), steps * dt).h
    return h[6:12], steps * dt


@pytest.mark.parametrize("scale", [1.0, 2.0], ids=["default added mass", "twice the added mass"])
@pytest.mark.parametrize("axis", range(6), ids=AXES)
def test_initial_acceleration_is_force_over_rigid_plus_added_mass(hull_only, open_water, axis, scale) -> None:
    """A step force (10 N) or torque (1 N m) along each hull axis gives, in the first physics step,
    the acceleration of Fossen's rigid-body plus added mass matrix, (M_RB + M_A)^-1 w, within 3%
    of its on-axis value on every axis. 3%: the trimmed hull's CoM is a few mm off the origin, so
    M_RB couples axes slightly, and velocity-dependent fluid terms are ~1e-3 of the inertial ones
    after 2 ms; a missing or wrongly placed added-mass term is off by far more."""
    p = with_hull(hull_only, added_mass=hull_only.hull.added_mass * scale)
    amp = 10.0 if axis < 3 else 1.0
    v, t = step_response(p, open_water, axis, amp)
    w = np.zeros(6)
    w[axis] = amp
    expected = np.linalg.solve(hull_mass_matrix(p), w)
    np.testing.assert_allclose(v / t, expected, atol=0.03 * abs(expected[axis]))


@pytest.mark.parametrize("axis", range(6), ids=AXES)
def test_the_experiment_detects_missing_added_mass(hull_only, open_water, axis) -> None:
    """Control: with the plant's added-mass handling off, the same experiment measures F/m, which
    is outside the 3% band above on every axis (so the test above can fail)."""
    off = PlantSettings(build=BuildOptions(gravity=False, added_mass=False))
    amp = 10.0 if axis < 3 else 1.0
    v, t = step_response(hull_only, open_water, axis, amp, settings=off)
    w = np.zeros(6)
    w[axis] = amp
    no_added = with_hull(hull_only, added_mass=np.zeros(6))
    with_added = np.linalg.solve(hull_mass_matrix(hull_only), w)[axis]
    assert v[axis] / t == pytest.approx(np.linalg.solve(hull_mass_matrix(no_added), w)[axis], rel=0.03)
    assert abs(v[axis] / t / with_added - 1.0) > 0.2


@pytest.mark.slow
@pytest.mark.parametrize("scale", [1.0, 2.0], ids=["default added mass", "twice the added mass"])
@pytest.mark.parametrize("wrench", [[20.0, 0, 10.0, 0, 0, 0], [0, 0, 0, 0, 0, 1.0]], ids=["force", "yaw torque"])
def test_step_response_stable_for_60_s(hull_only, open_water, scale, wrench) -> None:
    """A constant world wrench for 60 s on the neutrally buoyant hull (its CoB above its CoG gives
    the restoring moments of the real vehicle): no instability, a finite state, and a steady state
    (the transient decays: the largest change of the body speeds between consecutive seconds is
    at least 5 times smaller over the last 10 s than over the first 10 s)."""
    p = with_hull(neutral(hull_only, open_water.water.density),
                  added_mass=hull_only.hull.added_mass * scale)
    plant = Plant(p, open_water)
    plant.set_external_wrench("hull", np.array(wrench))
    u = zero_input(p)
    speeds = np.array([plant.step(u, 1.0).h[6:12] for _ in range(60)])
    assert np.all(np.isfinite(speeds))
    change = np.max(np.abs(np.diff(speeds, axis=0)), axis=1)
    assert change[-10:].max() < 0.2 * change[:10].max()
    assert np.linalg.norm(speeds[-1]) > 0.1


def test_velocity_dependent_added_mass_forces_follow_the_parameter_file(hull_only, open_water) -> None:
    """MuJoCo's fluid model on the hull's fluid ellipsoid (drag, lift and viscosity switched off,
    leaving its potential-flow terms) against Fossen's C_A(nu) nu with the parameter file's diagonal M_A
    (Fossen 2011, eq. 6.43): the force on the body is (A v) x omega and, with omega = 0, the Munk
    moment is (A v) x v. Random velocities; agreement within 1e-5 relative, 1e-6 absolute: the
    fit of the fluid ellipsoid is exact to 1e-12, the 1 mm centre-of-buoyancy marker sphere adds
    2e-6 kg of virtual mass."""
    p = with_hull(hull_only, mujoco_fluidcoef=np.zeros(5))
    inviscid = dataclasses.replace(open_water, water=dataclasses.replace(open_water.water, viscosity=0.0))
    plant = Plant(p, inviscid, NO_GRAVITY)
    A = p.hull.added_mass[:3]
    rng = np.random.default_rng(5)
    for _ in range(20):
        v, w = rng.normal(0, 0.3, 3), rng.normal(0, 0.5, 3)
        for omega in (w, np.zeros(3)):
            h = np.zeros(p.n_states)
            h[6:9], h[9:12] = v, omega
            plant.set_state(h)
            f = plant.data.qfrc_passive[:6]  # hull level: body axes = world axes
            np.testing.assert_allclose(f[:3], np.cross(A * v, omega), rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(f[3:], np.cross(A * v, v), rtol=1e-5, atol=1e-6)


def test_link_added_mass_about_the_elbow_at_home(params, open_water) -> None:
    """Links, a closed form: at the home posture the elbow carries the elbow and wrist links in a
    straight line perpendicular to its axis, so their cross-flow added mass m_t = C_a rho pi r^2 l
    adds I_A = sum m_t (d^2 + l^2 / 12) about the elbow (d: distance of each link's centre from the
    joint). The elbow's entry of the plant's joint-space inertia (MuJoCo's mass matrix with the
    plant's posture-dependent added mass, as the plant's data holds it after a reset) grows by
    exactly that (1e-9). Other postures and the coupling terms: tests/test_plant_inertia.py."""
    elbow, wrist = params.arm.links[2], params.arm.links[3]
    rho = open_water.water.density
    I_A = 0.0
    for lk, dk in ((elbow, elbow.length / 2), (wrist, elbow.length + wrist.length / 2)):
        m_t = lk.added_mass_coefficient * rho * np.pi * lk.radius**2 * lk.length
        I_A += m_t * (dk**2 + lk.length**2 / 12)
    elbow_inertia = {}
    for added in (True, False):
        plant = Plant(params, open_water, PlantSettings(build=BuildOptions(fixed_base=True, added_mass=added)))
        M = np.zeros((plant.model.nv, plant.model.nv))
        mujoco.mj_fullM(plant.model, plant.data, M)
        elbow_inertia[added] = M[2, 2]
    assert elbow_inertia[True] - elbow_inertia[False] == pytest.approx(I_A, rel=1e-9)
    assert I_A > 0.1 * elbow_inertia[False]  # large enough to matter
