"""Body-to-plane distances of the paper's model (superellipsoids placed by its kinematics) against
trimesh meshes placed by MuJoCo's kinematics, and closing speeds against finite differences."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from controller.model import UVMSModel
from uvms.scene import Plane
from uvms_mj.plant import Plant

RNG = np.random.default_rng(8)


@pytest.fixture(scope="module")
def model(params, scene) -> UVMSModel:
    return UVMSModel(params, scene.water)


def random_state(p) -> np.ndarray:
    n = p.n_joints
    h = np.zeros(p.n_states)
    h[:3], h[3:6] = RNG.normal(0, 0.5, 3), RNG.uniform(-1.2, 1.2, 3)
    h[6:6 + n] = p.arm.home + RNG.uniform(-0.8, 0.8, n)
    h[6 + n:] = RNG.normal(0, 0.5, 6 + n)
    return h


def test_distances_match_meshes_placed_by_mujoco(params, scene, model) -> None:
    """Every body's superellipsoid, meshed by trimesh (256 segments: inner approximation, 0.06 mm
    for 0.5 m semi-axes) and placed at MuJoCo's pose of that body's geom (hull ellipsoid, link
    capsule: same centre, capsule axis = superellipsoid z), is at the model's signed distance from
    random planes within 1 mm, including planes the bodies cut. 1 mm: the support function's
    smoothing keeps the model's distances conservative by up to 0.9 mm for these bodies and the
    mesh is 0.06 mm inside, so 1 mm holds both and catches a wrong pose, axis or semi-axis."""
    plant = Plant(params, scene.with_planes(()))
    m, d = plant.model, plant.data
    meshes = list(model.body_meshes(resolution=256).values())
    geoms = ["hull_geom"] + [f"{lk.name}_geom" for lk in params.arm.links]
    negative = 0
    for _ in range(20):
        h = random_state(params)
        plant.set_state(h)
        for _ in range(3):
            normal = Rotation.random(random_state=RNG).apply([0, 0, 1.0])
            offset = -normal @ (h[:3] + RNG.normal(0, 0.3, 3))
            got = np.asarray(model.distances(h, normal, offset)).ravel()
            for mesh, g, dist in zip(meshes, geoms, got, strict=True):
                gid = m.geom(g).id
                verts = mesh.vertices @ d.geom_xmat[gid].reshape(3, 3).T + d.geom_xpos[gid]
                ref = float(np.min(verts @ normal) + offset)
                assert abs(dist - ref) < 1e-3, g
                negative += dist < 0
    assert negative > 10  # the set includes penetrating planes


def test_closing_speeds_are_time_derivatives_of_distances(params, model) -> None:
    """d_dot equals the central difference of d along the model's own motion (h +- e hdot,
    e = 1e-6 s): 1e-6 relative (second-order truncation plus rounding)."""
    u = np.zeros(params.n_inputs)
    for _ in range(30):
        h = random_state(params)
        normal = Rotation.random(random_state=RNG).apply([0, 0, 1.0])
        offset = -normal @ (h[:3] + RNG.normal(0, 1.0, 3))
        hdot = model.hdot(h, u)
        e = 1e-6
        fd = (np.asarray(model.distances(h + e * hdot, normal, offset)) -
              np.asarray(model.distances(h - e * hdot, normal, offset))).ravel() / (2 * e)
        got = np.asarray(model.closing_speeds(h, normal, offset)).ravel()
        np.testing.assert_allclose(got, fd, rtol=1e-6, atol=1e-8)


def test_model_distances_are_conservative_against_the_plant_geometry(params, scene, model) -> None:
    """The controller's superellipsoids contain the plant's collision shapes (hull ellipsoid, link
    capsules; the end-effector tip is left out on purpose: it must reach the wall): for every body
    and plane the model's distance never exceeds MuJoCo's true distance (mj_geomDistance), up to
    1e-9 m of rounding. With the links' eps2 = 0.5 it would, by up to 3.5 mm."""
    planes = tuple(Plane.through(f"p{i}", RNG.normal(0, 0.3, 3), Rotation.random(random_state=RNG).apply([0, 0, 1.0]))
                   for i in range(4))
    plant = Plant(params, scene.with_planes(planes))
    rows = [plant.geom_names.index(g) for g in ["hull_geom"] + [f"{lk.name}_geom" for lk in params.arm.links]]
    for _ in range(20):
        h = random_state(params)
        plant.set_state(h)
        true = plant.signed_distances()[rows]
        for j, pl in enumerate(planes):
            got = np.asarray(model.distances(h, pl.normal, pl.offset)).ravel()
            assert np.all(got <= true[:, j] + 1e-9)
