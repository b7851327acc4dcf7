"""Contact: statics of the arm pressed on a plane, a hull resting on the seafloor, a hull hitting a wall."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from helpers import zero_input

from uvms.scene import Plane
from uvms_mj.build import EE_SITE, TIP_GEOM, BuildOptions
from uvms_mj.plant import Plant, PlantSettings

FIXED_NO_GRAVITY = PlantSettings(build=BuildOptions(gravity=False, fixed_base=True))


def arm_pressing(params, scene, force_world: np.ndarray, friction: float):
    """Hull welded to the world, no gravity, the arm at home; a plane just under the end-effector
    tip (normal +z). Returns the plant and the statics map J^T of the contact point, the bottom of
    the tip sphere (J^T F = generalized force of a force F there, from joint axes and anchors)."""
    probe = Plant(params, scene.with_planes(()), FIXED_NO_GRAVITY)
    m, d = probe.model, probe.data
    tip = d.site_xpos[m.site(EE_SITE).id].copy()
    contact = tip - [0, 0, params.arm.tip_radius]
    plane = Plane.through("floor", contact, [0, 0, 1], friction)
    plant = Plant(params, scene.with_planes((plane,)), FIXED_NO_GRAVITY)
    JT = np.array([np.cross(d.xaxis[m.joint(f"{lk.name}_joint").id],
                            contact - d.xanchor[m.joint(f"{lk.name}_joint").id]) for lk in params.arm.links])
    return plant, JT


@pytest.mark.parametrize(("force", "friction"), [
    ([0.0, 0.0, 15.0], 0.0),
    ([3.0, -2.0, 15.0], 0.5),
], ids=["frictionless normal push", "push with friction inside the cone"])
def test_arm_contact_force_matches_statics(params, scene, force, friction) -> None:
    """The arm pushes the plane with joint torques tau = -J^T F (plus a stiff joint servo that
    holds the posture: a torque-driven arm on a plane is a mechanism, otherwise it slides). At
    rest, statics predicts the tip force from the torques MuJoCo actually applies,
    F = -pinv(J^T) tau; the measured contact force agrees within 5% of |F|
    (5%: room for the soft contact and the servo's residual motion; a wrong Jacobian, sign or frame
    is off by far more)."""
    F = np.array(force)
    plant, JT = arm_pressing(params, scene, F, friction)
    nt, nj = params.n_thrusters, params.n_joints
    q0, tau_ff = params.arm.home.copy(), -JT @ F
    M = np.zeros((plant.model.nv, plant.model.nv))
    mujoco.mj_fullM(plant.model, plant.data, M)
    inertia = np.diag(M)  # servo: 5 Hz, critically damped, per joint
    kp, kd = (2 * np.pi * 5) ** 2 * inertia, 2 * (2 * np.pi * 5) * inertia
    dt = plant.model.opt.timestep
    for _ in range(int(2.0 / dt)):
        h = plant.state()
        q, qd = h[6:6 + nj], h[12 + nj:]
        tau = tau_ff + kp * (q0 - q) - kd * qd
        r = plant.step(np.concatenate([np.zeros(nt), tau]), dt)
    # Quasi-static: MuJoCo's soft friction lets a sustained tangential load creep (~1e-3 rad/s).
    assert np.linalg.norm(r.h[12 + nj:]) < 1e-2
    tau_applied = r.u_applied[nt:]
    predicted = -np.linalg.pinv(JT) @ tau_applied
    assert np.linalg.norm(JT @ predicted + tau_applied) < 1e-3 * np.linalg.norm(tau_applied)  # consistent
    np.testing.assert_allclose(r.ee_wrench[:3], predicted, atol=0.05 * np.linalg.norm(F))
    np.testing.assert_allclose(predicted, F, atol=0.05 * np.linalg.norm(F))  # the servo barely helps


def test_wrist_sensor_reads_the_contact_wrench_about_the_ee_point(params, scene) -> None:
    """The arm pushes a plane with friction as above (a tangential load inside the cone, held 1 s).
    The wrist sensor's period mean (PlantReport.wrist_impulse / period) against statics: its force
    is the statics force F = -pinv(J^T) tau from the applied torques within 5% of |F| (the same
    room as above: soft contact, servo residue), and its torque about the EE point is r x F, r from
    the tip sphere's centre to its bottom, where it touches, within 5% of r_t |F| (the contact point
    of a soft contact sinks a fraction of a mm into the plane; a wrong lever or sign is off by
    100% or more). And MuJoCo's own per-body external wrench (cfrc_ext, from mj_rnePostConstraint)
    of the last link, moved to the EE point, equals the sensor's instantaneous reading to 1e-9."""
    F = np.array([3.0, -2.0, 15.0])
    plant, JT = arm_pressing(params, scene, F, 0.5)
    m, d = plant.model, plant.data
    nt, nj = params.n_thrusters, params.n_joints
    q0, tau_ff = params.arm.home.copy(), -JT @ F
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    kp, kd = (2 * np.pi * 5) ** 2 * np.diag(M), 2 * (2 * np.pi * 5) * np.diag(M)
    dt = m.opt.timestep
    for _ in range(int(1.0 / dt)):
        q, qd = plant.state()[6:6 + nj], plant.state()[12 + nj:]
        r = plant.step(np.concatenate([np.zeros(nt), tau_ff + kp * (q0 - q) - kd * qd]), dt)
    period = 10 * dt
    r = plant.step(r.u_applied, period)
    mean = r.wrist_impulse / period
    predicted = -np.linalg.pinv(JT) @ r.u_applied[nt:]
    lever = np.array([0.0, 0.0, -params.arm.tip_radius])
    np.testing.assert_allclose(mean[:3], predicted, atol=0.05 * np.linalg.norm(F))
    np.testing.assert_allclose(mean[3:], np.cross(lever, predicted),
                               atol=0.05 * params.arm.tip_radius * np.linalg.norm(F))
    mujoco.mj_rnePostConstraint(m, d)
    last = m.body(params.arm.links[-1].name).id
    torque_c, force = d.cfrc_ext[last, :3], d.cfrc_ext[last, 3:]
    centre = d.subtree_com[m.body_rootid[last]]
    about_ee = torque_c + np.cross(centre - d.site_xpos[m.site(EE_SITE).id], force)
    np.testing.assert_allclose(plant.wrist_wrench(), np.concatenate([force, about_ee]), rtol=0, atol=1e-9)


def test_resting_hull_presses_with_its_net_weight(hull_only, scene) -> None:
    """A slightly heavy hull resting on the seafloor: the contact force on it is +z with magnitude
    (m - rho V) g within 1% (static equilibrium; the fluid forces vanish at rest)."""
    floor = Plane.through("seafloor", [0, 0, -0.2], [0, 0, 1], 0.5)
    plant = Plant(hull_only, scene.with_planes((floor,)))
    for _ in range(100):
        r = plant.step(zero_input(hull_only), 0.1)
    (c,) = r.contacts
    assert (c.body, c.plane) == ("hull", "seafloor")
    w = scene.water
    expected = (hull_only.hull.mass - w.density * hull_only.hull.volume) * w.gravity
    np.testing.assert_allclose(c.force, [0, 0, expected], rtol=0.01, atol=1e-6)
    assert c.impulse[2] == pytest.approx(expected * 0.1, rel=0.01)


def test_hull_hitting_a_wall_reports_an_impulse(hull_only, scene) -> None:
    """The hull coasting at 0.5 m/s into a wall 7 cm ahead: a positive normal impulse, bounded by
    twice its momentum including added mass (the elastic limit), and the hull stops or rebounds."""
    wall = Plane.through("wall", [0.3, 0, 0], [-1, 0, 0], 0.5)
    plant = Plant(hull_only, scene.with_planes((wall,)))
    h = np.zeros(hull_only.n_states)
    h[6] = 0.5
    plant.reset(h)
    impulse, peak = np.zeros(3), 0.0
    for _ in range(20):
        r = plant.step(zero_input(hull_only), 0.1)
        for c in r.contacts:
            assert (c.body, c.plane) == ("hull", "wall")
            impulse += c.impulse
            peak = max(peak, c.peak_normal_force)
    momentum = (hull_only.hull.mass + hull_only.hull.added_mass[0]) * 0.5
    normal_impulse = impulse @ wall.normal
    assert 0.0 < normal_impulse < 2 * momentum
    assert peak > 0.0
    assert r.h[6] <= 0.0


def test_contact_force_sign_agrees_with_mujoco_contact_frame(hull_only, scene) -> None:
    """Cross-check of the report's sign convention with MuJoCo's efc-based body force: the
    constraint force on the resting hull (qfrc_constraint) points up like the reported force."""
    floor = Plane.through("seafloor", [0, 0, -0.2], [0, 0, 1], 0.5)
    plant = Plant(hull_only, scene.with_planes((floor,)))
    for _ in range(50):
        r = plant.step(zero_input(hull_only), 0.1)
    mujoco.mj_forward(plant.model, plant.data)
    assert plant.data.qfrc_constraint[2] > 0 and r.contacts[0].force[2] > 0
    assert plant.data.qfrc_constraint[2] == pytest.approx(r.contacts[0].force[2], rel=1e-3)


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 60.0, 80.0, 90.0, 100.0])
@pytest.mark.parametrize("side", [1, 2], ids=["across y", "across z"])
def test_tip_leads_the_last_link_into_a_plane(params, scene, angle_deg, side) -> None:
    """Mode III's contact is the end-effector's: the tip sphere must reach a plane before the last
    link's capsule does, whichever way the link meets it up to side-on. A plane in front of the tip,
    its normal `angle_deg` off the link's axis. Oracle: the closed form for a sphere of radius r_t at
    L_t on the axis against the capsule (radius r_c, axis from 0 to L_c): the capsule is farther by
    L_t cos(a) + r_t - max(L_c cos(a), 0) - r_c, > 0 up to 92 deg with the parameter file's values
    (100 deg checks the other sign). MuJoCo's own distances (mj_geomDistance) agree within 1e-6 m
    (collision-detector precision)."""
    arm = params.arm
    last = arm.links[-1]
    probe = Plant(params, scene.with_planes(()), FIXED_NO_GRAVITY)
    m, d = probe.model, probe.data
    tip_centre = d.site_xpos[m.site(EE_SITE).id].copy()
    R = d.xmat[m.body(last.name).id].reshape(3, 3)
    a = np.radians(angle_deg)
    towards = np.cos(a) * R[:, 0] + np.sin(a) * R[:, side]
    plane = Plane.through("probe", tip_centre + (arm.tip_radius + 0.05) * towards, -towards, 0.5)
    plant = Plant(params, scene.with_planes((plane,)), FIXED_NO_GRAVITY)
    dist = plant.signed_distances()[:, 0]
    tip, link = dist[plant.geom_names.index(TIP_GEOM)], dist[plant.geom_names.index(f"{last.name}_geom")]
    expected = arm.end_effector[0] * np.cos(a) + arm.tip_radius - max(last.length * np.cos(a), 0.0) - last.radius
    assert tip == pytest.approx(0.05, abs=1e-6)
    assert link - tip == pytest.approx(expected, abs=1e-6)
    assert (link - tip > 0.0) == (angle_deg <= 90.0)
