"""The plant's inertia is the model's: hull and links' added mass in every posture, at any ratio
to the rigid inertia, with and without contact, over a long run."""

from __future__ import annotations

import dataclasses
import warnings

import mujoco
import numpy as np
import pytest
from oracles.added_mass import PinocchioAddedMassOracle

from controller.model import ModelOptions, UVMSModel
from controller.model import water as still_water
from uvms import load_params
from uvms.conventions import euler_zyx_to_matrix
from uvms.params import UVMSParams
from uvms.scene import Scene
from uvms_mj.added_mass import AddedMassSolveWarning
from uvms_mj.build import BuildOptions
from uvms_mj.plant import Plant, PlantSettings, PlantUnstableError

TOL = 1e-6  # relative: the agreement asked of the plant's initial accelerations
# Fluid velocity terms off (no MuJoCo fluid model), added mass on; joint friction and limits off
# (the model has neither); gravity and buoyancy on.
AT_REST = BuildOptions(fluid=False, joint_damping=False, joint_limits=False)


def with_added_mass(p: UVMSParams, scale: float) -> UVMSParams:
    """The vehicle with its hull added mass and every link's C_a multiplied by `scale`."""
    links = tuple(dataclasses.replace(lk, added_mass_coefficient=lk.added_mass_coefficient * scale)
                  for lk in p.arm.links)
    return dataclasses.replace(p, hull=dataclasses.replace(p.hull, added_mass=p.hull.added_mass * scale),
                               arm=dataclasses.replace(p.arm, links=links))


def random_rest_state(p: UVMSParams, rng: np.random.Generator) -> np.ndarray:
    """At rest (nu = 0): position in a 2 m box, any roll and yaw, |pitch| <= 1.3 rad, joints uniform
    in their ranges."""
    n = p.n_joints
    lo, hi = np.array([lk.joint_range for lk in p.arm.links]).T
    h = np.zeros(p.n_states)
    h[:3] = rng.uniform(-1, 1, 3)
    h[3:6] = [rng.uniform(-np.pi, np.pi), rng.uniform(-1.3, 1.3), rng.uniform(-np.pi, np.pi)]
    h[6:6 + n] = rng.uniform(lo, hi)
    return h


def rel(a: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(a - ref) / np.linalg.norm(ref))


@pytest.mark.parametrize("scale", [1.0, 3.0], ids=["file's added mass", "3x added mass"])
@pytest.mark.parametrize("arm", ["alpha4", "alpha6"])
def test_initial_acceleration_equals_the_models_and_pinocchios(scene: Scene, arm: str, scale: float) -> None:
    """30 random postures and attitudes at rest, a random hull wrench (world frame, at the hull
    origin; ~N(0, 20 N), ~N(0, 2 N m)) and random joint torques (uniform within 80% of their limits),
    fluid velocity terms
    off, added mass, gravity and buoyancy on: the plant's initial nu_dot (`Plant.acceleration`)
    equals (1) the paper's model, M(q)^-1 (Q - b) from controller/model.py, and (2) Pinocchio's CRBA
    and RNEA plus the parameter file's added mass through Pinocchio's frame Jacobians and buoyancy
    at the centres of buoyancy (tests/oracles/added_mass.py), to 1e-6 relative (both are exact
    constructions in double precision: measured ~1e-14).

    Control, computed here from the old formula: the old plant's inertia, the model's rigid matrix
    plus the hull's added mass plus each link's added mass as hinge armature at the home posture
    (the diagonal joint entries of the links' added mass there), errs by more than 10x the
    tolerance on every state (measured: at least 0.018, up to 0.82 relative), so the comparison can
    fail."""
    p = with_added_mass(load_params(arm=arm), scale)
    water = scene.with_planes(())
    plant = Plant(p, water, PlantSettings(build=AT_REST))
    model = UVMSModel(p, water.water, ModelOptions(drag=False))
    no_links = UVMSModel(with_added_mass_links_off(p), water.water, ModelOptions(drag=False))
    pin_oracle = PinocchioAddedMassOracle(p, water.water.density, water.water.gravity)
    n, rng = p.n_joints, np.random.default_rng(int(10 * scale) + n_of(arm))
    home = np.zeros(p.n_states)
    home[6:6 + n] = p.arm.home
    link_home = np.diag(np.asarray(model.mass_matrix(home)) - np.asarray(no_links.mass_matrix(home)))[6:]
    worst = dict(model=0.0, pinocchio=0.0, old=np.inf, old_max=0.0)
    limits = np.array([lk.torque_limit for lk in p.arm.links])  # N m: inside them, nothing is clipped
    for _ in range(30):
        h = random_rest_state(p, rng)
        wrench = rng.normal(0, [20.0, 20, 20, 2, 2, 2])
        tau = rng.uniform(-0.8, 0.8, n) * limits
        plant.set_state(h)
        plant.set_external_wrench("hull", wrench)
        got = plant.acceleration(np.concatenate([np.zeros(p.n_thrusters), tau]))
        R = euler_zyx_to_matrix(*h[3:6])
        Q = np.concatenate([R.T @ wrench[:3], R.T @ wrench[3:], tau])
        b = np.asarray(model.bias(h, still_water(), np.zeros(3))).ravel()
        expect = np.linalg.solve(np.asarray(model.mass_matrix(h)), Q - b)
        oracle = np.linalg.solve(pin_oracle.mass_matrix(h), Q - pin_oracle.bias_at_rest(h))
        M_old = np.asarray(no_links.mass_matrix(h)) + np.diag(np.r_[np.zeros(6), link_home])
        old = np.linalg.solve(M_old, Q - b)
        worst["model"] = max(worst["model"], rel(got, expect))
        worst["pinocchio"] = max(worst["pinocchio"], rel(got, oracle))
        worst["old"] = min(worst["old"], rel(old, expect))
        worst["old_max"] = max(worst["old_max"], rel(old, expect))
    print(f"{arm}, {scale}x added mass: worst relative error {worst} (old: smallest and largest)")
    assert worst["model"] < TOL and worst["pinocchio"] < TOL, worst
    assert worst["old"] > 10 * TOL, worst
    assert plant.added_mass.failures == 0


def with_added_mass_links_off(p: UVMSParams) -> UVMSParams:
    """The same vehicle with no added mass on the links (C_a = 0)."""
    return dataclasses.replace(p, arm=dataclasses.replace(p.arm, links=tuple(
        dataclasses.replace(lk, added_mass_coefficient=0.0) for lk in p.arm.links)))


def n_of(arm: str) -> int:
    return int(arm.removeprefix("alpha"))


def test_a_physics_step_integrates_the_same_accelerations(params: UVMSParams, scene: Scene) -> None:
    """MuJoCo's implicitfast step solves with the mass matrix the plant augmented: with nothing
    velocity-dependent (fluid, joint friction off; no gravity, so no righting moment; still water),
    one step of dt from a random posture at rest changes qvel by exactly dt qacc of the plant's
    forward dynamics (1e-12 relative: the same linear solve; a step that solved with the rigid
    mass matrix would differ by the added mass's share, tens of percent)."""
    opts = dataclasses.replace(AT_REST, gravity=False)
    plant = Plant(with_added_mass(params, 3.0), scene.with_planes(()), PlantSettings(build=opts))
    rng = np.random.default_rng(7)
    for _ in range(5):
        plant.set_state(random_rest_state(plant.params, rng))
        plant.set_external_wrench("hull", rng.normal(0, [20.0, 20, 20, 2, 2, 2]))
        limits = np.array([lk.torque_limit for lk in plant.params.arm.links])
        u = np.concatenate([np.zeros(plant.params.n_thrusters), rng.uniform(-0.8, 0.8, len(limits)) * limits])
        plant.acceleration(u)
        qvel, qacc = plant.data.qvel.copy(), plant.data.qacc.copy()
        plant.step(u, plant.model.opt.timestep)
        dv = plant.data.qvel - qvel
        assert rel(dv, plant.model.opt.timestep * qacc) < 1e-12


def test_contact_accelerations_equal_the_implicit_added_mass_force(params: UVMSParams, scene: Scene) -> None:
    """Under contact the added mass enters MuJoCo's constraint solver exactly: the vehicle driven
    into the wall (30 N on the horizontal thrusters, the arm moving) until a geom touches it; then the
    plant's accelerations equal those of MuJoCo's own solver with the rigid mass matrix and the
    added-mass force -A(q) qacc applied and iterated to its fixed point (relaxed, to 1e-12 N: the
    implicit solution the old plant iterated towards), to 1e-9 relative.

    Both sides have MuJoCo's noslip pass off: noslip solves the friction rows with the constraint
    inertia J M^-1 J^T, which in the plant is J (M + A)^-1 J^T (the vehicle's true inertia) but in
    the iterated construction J M^-1 J^T: the two then differ by design (measured 1.6% on this
    state), and the plant's is the consistent one."""
    plant = Plant(params, scene)
    m, d = plant.model, plant.data
    u = np.r_[np.full(4, 30.0), np.zeros(params.n_thrusters - 4), [0.5, -0.5, 0.3, 0.2][:params.n_joints]]
    for _ in range(60):
        report = plant.step(u, 0.1)
        if report.contacts:
            break
    assert report.contacts, "the vehicle did not reach the wall"
    m.opt.noslip_iterations = 0
    got = plant.acceleration(u)
    qacc = d.qacc.copy()
    assert d.ncon > 0
    A = plant.added_mass.matrix(d)
    f = np.zeros(m.nv)
    for _ in range(500):
        d.qfrc_applied[:] = f
        mujoco.mj_forward(m, d)
        f_new = -A @ d.qacc
        if np.max(np.abs(f_new - f)) < 1e-12:
            break
        f = 0.5 * (f + f_new)
    else:
        pytest.fail("the iterated added-mass force did not converge")
    d.qfrc_applied[:] = 0.0
    assert rel(qacc, d.qacc) < 1e-9
    assert np.all(np.isfinite(got))


def test_sixty_seconds_at_three_times_the_added_mass(params: UVMSParams, scene: Scene) -> None:
    """60 s of the full plant (fluid, buoyancy, joint friction and limits on) at 3x the file's added
    mass (hull and links; remainder-to-inertia ratio ~0.36, where the old iteration hit its cap),
    tilted 30 deg in roll and 20 in pitch, random thruster and joint inputs switched every 0.1 s
    (uniform within +-50% and +-40% of their limits, so the arm swings through its range and
    against its limits): the state stays finite, MuJoCo raises no instability, no warning is
    issued and no step's added-mass solve fails."""
    p = with_added_mass(params, 3.0)
    plant = Plant(p, scene.with_planes(()))
    h = np.zeros(p.n_states)
    h[2], h[3], h[4] = 0.0, np.deg2rad(30.0), np.deg2rad(20.0)
    h[6:6 + p.n_joints] = p.arm.home
    plant.reset(h)
    lo, hi = p.input_bounds()
    span = np.r_[np.full(p.n_thrusters, 0.5), np.full(p.n_joints, 0.4)]
    rng = np.random.default_rng(11)
    failures, joint_travel = 0, np.zeros(p.n_joints)
    q0 = h[6:6 + p.n_joints]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for _ in range(600):
            u = 0.5 * (lo + hi) + span * 0.5 * (hi - lo) * rng.uniform(-1, 1, p.n_inputs)
            r = plant.step(u, 0.1)
            failures += r.added_mass_failures
            assert np.all(np.isfinite(r.h))
            joint_travel = np.maximum(joint_travel, np.abs(r.h[6:6 + p.n_joints] - q0))
    assert failures == 0 and plant.added_mass.failures == 0
    assert np.all(joint_travel > 0.3), joint_travel  # the arm moved (rad)


def test_a_failed_factorization_is_counted_and_warned(params: UVMSParams, scene: Scene) -> None:
    """Control of the failure report: a (non-physical) negative added mass on a link larger than
    its rigid inertia makes the augmented mass matrix indefinite; the plant counts the step in the
    report and warns (AddedMassSolveWarning), and MuJoCo's bad accelerations then raise."""
    lk = params.arm.links[-1]
    bad = dataclasses.replace(params, arm=dataclasses.replace(params.arm, links=(
        *params.arm.links[:-1], dataclasses.replace(lk, added_mass_coefficient=-50.0))))
    with pytest.warns(AddedMassSolveWarning):
        plant = Plant(bad, scene.with_planes(()), PlantSettings(build=AT_REST))
    assert plant.added_mass.failures == 1
    with pytest.warns(AddedMassSolveWarning), pytest.raises(PlantUnstableError):
        plant.step(np.zeros(bad.n_inputs), plant.model.opt.timestep)
    assert plant.added_mass.failures == 2
