"""The plant's interface: thruster faults, determinism, distances, bad input, instability."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import hull_mass_matrix, zero_input

from uvms.scene import Plane
from uvms_mj.plant import FaultMode, Plant, PlantSettings, PlantUnstableError, ThrusterFault

RNG = np.random.default_rng(11)


def test_failed_thruster_applies_no_force_and_the_others_still_act(hull_only, open_water) -> None:
    """Thruster 0 fails at t = 0.2 s. Before: every commanded force is applied. After: thruster 0
    applies 0 N, the others their command, and the hull's initial acceleration is the allocation
    of the remaining thrusts through (M_RB + M_A)^-1 (within 3%, as the added-mass test)."""
    fault = ThrusterFault("t1_front_starboard", start_time=0.2, mode=FaultMode.ZERO)
    plant = Plant(hull_only, open_water, PlantSettings(faults=(fault,)))
    u = np.full(hull_only.n_inputs, 10.0)
    r = plant.step(u, 0.1)
    np.testing.assert_allclose(r.u_applied, u)
    plant.step(u, 0.1)
    r = plant.step(u, 0.1)
    expected = u.copy()
    expected[0] = 0.0
    np.testing.assert_allclose(r.u_applied, expected)
    # The remaining seven thrusters still act: from rest, surge acceleration of their allocation.
    plant = Plant(hull_only, open_water, PlantSettings(faults=(ThrusterFault(0),)))
    surge = np.array([10.0, 10.0, 10.0, 10.0, 0, 0, 0, 0])  # four horizontal thrusters
    dt = plant.model.opt.timestep
    v = plant.step(surge, dt).h[6:12]
    wrench = hull_only.allocation_matrix() @ (surge * [0, 1, 1, 1, 1, 1, 1, 1])
    expected = np.linalg.solve(hull_mass_matrix(hull_only), wrench)
    np.testing.assert_allclose(v / dt, expected, atol=0.03 * np.abs(expected).max())


def test_stuck_thruster_applies_its_stuck_force(hull_only, open_water) -> None:
    fault = ThrusterFault(3, start_time=0.0, mode=FaultMode.STUCK, value=-25.0)
    plant = Plant(hull_only, open_water, PlantSettings(faults=(fault,)))
    r = plant.step(np.zeros(hull_only.n_inputs), 0.1)
    assert r.u_applied[3] == -25.0
    assert np.all(np.delete(r.u_applied, 3) == 0.0)


def test_unknown_fault_thruster_is_a_clear_error(hull_only, open_water) -> None:
    with pytest.raises(ValueError, match=r"allowed: an index 0\.\.7 or one of t1_front_starboard"):
        Plant(hull_only, open_water, PlantSettings(faults=(ThrusterFault("t9"),)))


def test_same_inputs_give_bit_identical_states(params, scene) -> None:
    """Two plants, the same random inputs for 3 s with the vehicle driven into the wall: identical
    bits (MuJoCo is deterministic on one thread; the plant adds no randomness)."""
    wall = Plane.through("wall", [0.9, 0, 0], [-1, 0, 0], 0.5)
    lo, hi = params.input_bounds()
    inputs = RNG.uniform(lo, hi, (30, params.n_inputs))
    inputs[:, :4] = np.abs(inputs[:, :4])  # horizontal thrusters push forward: contact happens
    runs = []
    for _ in range(2):
        plant = Plant(params, scene.with_planes((wall,)))
        runs.append([plant.step(u, 0.1) for u in inputs])
    assert any(r.contacts for r in runs[0])
    for a, b in zip(*runs, strict=True):
        assert np.array_equal(a.h, b.h)
        assert np.array_equal(a.distances, b.distances)


def test_signed_distances_equal_the_closed_forms(params, scene) -> None:
    """MuJoCo's geom distances to tilted planes equal the closed forms of each shape within 1e-9 m:
    ellipsoid n.c + D - |diag(a) R^T n|, capsule n.c + D - |n.axis| l/2 - r, sphere n.c + D - r."""
    planes = tuple(Plane.through(f"p{i}", RNG.normal(size=3), RNG.normal(size=3)) for i in range(3))
    plant = Plant(params, scene.with_planes(planes))
    m, d = plant.model, plant.data
    for _ in range(20):
        h = np.zeros(params.n_states)
        h[:3], h[3:6] = RNG.normal(size=3), RNG.uniform(-1, 1, 3)
        h[6:6 + params.n_joints] = params.arm.home + RNG.uniform(-0.5, 0.5, params.n_joints)
        plant.set_state(h)
        D = plant.signed_distances()
        for i, name in enumerate(plant.geom_names):
            g = m.geom(name).id
            R, c, size = d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g], m.geom_size[g]
            for j, pl in enumerate(planes):
                base = pl.signed_distance(c)
                if name == "hull_geom":
                    ref = base - np.linalg.norm(size * (R.T @ pl.normal))
                elif name == "ee_tip":
                    ref = base - size[0]
                else:
                    ref = base - abs(pl.normal @ R[:, 2]) * size[1] - size[0]
                assert D[i, j] == pytest.approx(ref, abs=1e-9)


@pytest.mark.parametrize(("bad", "match"), [
    (np.zeros(5), r"shape \(5,\); allowed: \(20,\)"),
    (np.r_[np.nan, np.zeros(19)], "non-finite entries at \\[0\\]"),
])
def test_bad_state_is_a_clear_error(params, scene, bad, match) -> None:
    with pytest.raises(ValueError, match=match):
        Plant(params, scene).set_state(bad)


def test_bad_input_and_duration_are_clear_errors(params, scene) -> None:
    plant = Plant(params, scene)
    with pytest.raises(ValueError, match=r"input u has shape \(3,\); allowed: \(12,\)"):
        plant.step(np.zeros(3), 0.1)
    with pytest.raises(ValueError, match="input u has non-finite"):
        plant.step(np.full(12, np.inf), 0.1)
    with pytest.raises(ValueError, match="allowed: a positive multiple of the physics timestep"):
        plant.step(np.zeros(12), 0.0031)


def test_input_outside_limits_is_clipped_and_reported(params, scene) -> None:
    """Documented policy: clip to the limits, report which entries were clipped."""
    plant = Plant(params, scene)
    u = np.zeros(params.n_inputs)
    u[0], u[9] = 100.0, -50.0  # thruster limit 40 N, shoulder torque limit 10 N m
    r = plant.step(u, 0.1)
    assert r.clipped.tolist() == [i in (0, 9) for i in range(params.n_inputs)]
    assert r.u_applied[0] == 40.0 and r.u_applied[9] == -10.0


def test_instability_raises_instead_of_continuing(params, scene) -> None:
    plant = Plant(params, scene)
    plant.set_external_wrench("hull", np.array([1e14, 0, 0, 0, 0, 0]))
    with pytest.raises(PlantUnstableError, match="mjWARN_BADQACC"):
        plant.step(zero_input(params), 0.1)
