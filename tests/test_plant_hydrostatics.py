"""Hydrostatics of the plant against closed forms: net buoyancy, righting moment, settling."""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np
import pytest
from helpers import neutral, with_hull, zero_input

from uvms.conventions import euler_zyx_to_matrix
from uvms_mj.plant import Plant


@pytest.mark.parametrize("volume", [0.0134, 0.0200], ids=["literature (slightly heavy)", "buoyant"])
def test_initial_vertical_acceleration(hull_only, open_water, volume: float) -> None:
    """From rest, with no thrust: a_z = (rho V - m) g / (m + m_A,heave) within 2%.

    Measured as the velocity after one 2 ms physics step (drag ~ v^2 is still ~1e-8 of the net
    force). 2%: the plant's construction is exact up to the 1e-3 kg centre-of-buoyancy bodies,
    which are compensated, so 2% catches a wrong sign or a missing term (the heave added mass).
    """
    p = with_hull(hull_only, volume=volume)
    plant = Plant(p, open_water)
    dt = plant.model.opt.timestep
    h = plant.step(zero_input(p), dt).h
    rho, g, H = open_water.water.density, open_water.water.gravity, p.hull
    expected = (rho * volume - H.mass) * g / (H.mass + H.added_mass[2])
    assert h[8] / dt == pytest.approx(expected, rel=0.02)


def test_righting_moment_at_30_degrees_roll(hull_only, open_water) -> None:
    """MuJoCo's generalized force on the hull's rotational DOFs at 30 deg roll, at rest, equals the
    closed form of buoyancy rho V g acting at the CoB offset d above the CoG: -rho V g d sin(phi)
    about x (restoring), within 2%."""
    plant = Plant(hull_only, open_water)
    phi = np.radians(30.0)
    h = np.zeros(hull_only.n_states)
    h[3] = phi
    plant.set_state(h)
    d = plant.data
    torque_body = (d.qfrc_passive - d.qfrc_bias)[3:6]  # free joint: about the body origin, body frame
    rho, g, H = open_water.water.density, open_water.water.gravity, hull_only.hull
    R = euler_zyx_to_matrix(phi, 0.0, 0.0)
    closed_world = np.cross(R @ H.cob, [0.0, 0.0, rho * H.volume * g])
    closed_body = R.T @ closed_world
    assert closed_body[0] == pytest.approx(-rho * H.volume * g * H.cob[2] * np.sin(phi))
    np.testing.assert_allclose(torque_body, closed_body, rtol=0.02, atol=1e-9)


def test_full_vehicle_gravity_and_buoyancy_forces(params, open_water) -> None:
    """Whole vehicle, any attitude and posture: the net vertical force MuJoCo applies at rest is
    sum(rho V_i - m_i) g, exactly the parameter file's masses and volumes (rel 1e-6)."""
    plant = Plant(params, open_water)
    rng = np.random.default_rng(3)
    rho, g = open_water.water.density, open_water.water.gravity
    net = (rho * params.hull.volume - params.hull.mass
           + sum(rho * lk.volume - lk.mass for lk in params.arm.links)) * g
    for _ in range(10):
        h = np.zeros(params.n_states)
        h[3:6] = rng.uniform(-0.6, 0.6, 3)
        h[6:6 + params.n_joints] = params.arm.home + rng.uniform(-0.3, 0.3, params.n_joints)
        plant.set_state(h)
        # Sum of the passive (buoyancy) and gravity generalized forces on the free joint's
        # translational DOFs = total world force on the system.
        fz = (plant.data.qfrc_passive - plant.data.qfrc_bias)[2]
        assert fz == pytest.approx(net, rel=1e-6)


@pytest.mark.parametrize("spec", ["", "mass*1.2", "mass_weight*0.85 current+0.2"])
def test_trim_check_measures_the_parameter_files_weight_in_water(params, scene, spec: str) -> None:
    """Plant.trim_weight (MuJoCo's inverse dynamics at rest, flow and contacts off) at a tilted pose
    beside the walls equals the closed form sum (m_i - rho V_i) g of the drawn vehicle's parameters
    (UVMSParams.weight_in_water; rel 1e-9 plus 1e-9 N: the same numbers summed two ways), and leaves
    the plant's state, current and contacts as they were."""
    from validation import mismatch

    drawn, rho, g = mismatch.draw(spec, 0), scene.water.density, scene.water.gravity
    plant_params, plant_scene, current, _ = mismatch.apply(params, scene, drawn)
    plant = Plant(plant_params, plant_scene.with_current(replace(plant_scene.current,
                                                                 velocities=plant_scene.current.velocities + current)))
    h = np.zeros(params.n_states)
    h[3:6], h[6:6 + params.n_joints] = (0.2, -0.3, 0.5), params.arm.home
    plant.reset(h)
    before, wind, flags = plant.state(), plant.model.opt.wind.copy(), plant.model.opt.disableflags
    assert plant.trim_weight() == pytest.approx(plant_params.weight_in_water(rho, g), rel=1e-9, abs=1e-9)
    np.testing.assert_array_equal(plant.state(), before)
    np.testing.assert_array_equal(plant.model.opt.wind, wind)
    assert plant.model.opt.disableflags == flags
    if "mass*" in spec:
        extra = plant.trim_weight() - params.weight_in_water(rho, g)
        assert extra == pytest.approx(0.2 * params.hull.mass * g, rel=1e-9)


def test_default_vehicle_is_trimmed_level_and_slightly_buoyant(params, open_water) -> None:
    """With the arm at home and the hull upright, MuJoCo's net hydrostatic force on the default
    vehicle is +0.05 kg of lift (within 0.01 kg) and its roll and pitch moments about the hull
    origin are below 0.02 N m (the trim in the parameter file was chosen for that)."""
    plant = Plant(params, open_water)
    h = np.zeros(params.n_states)
    h[6:6 + params.n_joints] = params.arm.home
    plant.set_state(h)
    f = (plant.data.qfrc_passive - plant.data.qfrc_bias)[:6]
    assert f[2] / open_water.water.gravity == pytest.approx(0.05, abs=0.01)
    assert np.all(np.abs(f[3:5]) < 0.02)


@pytest.mark.slow
def test_tilted_hull_settles_upright(hull_only, open_water) -> None:
    """Released at 30 deg roll and 20 deg pitch with no thrust, the hull rights itself: after 60 s
    both angles are below 1 deg (the CoB is 1 cm above the CoG; MuJoCo's fluid damps the swing)."""
    p = neutral(hull_only, open_water.water.density)
    plant = Plant(p, open_water)
    h = np.zeros(p.n_states)
    h[3], h[4] = np.radians(30.0), np.radians(20.0)
    plant.reset(h)
    for _ in range(600):
        r = plant.step(zero_input(p), 0.1)
    assert abs(np.degrees(r.h[3])) < 1.0
    assert abs(np.degrees(r.h[4])) < 1.0
    assert mujoco.mj_getTotalmass(plant.model) == pytest.approx(p.hull.mass)
