"""Superellipsoid support function, plane distance and closing speed against independent oracles: the paper's
implicit equation, trimesh meshes, finite differences along rigid motions (scipy rotations) and closed forms."""

from __future__ import annotations

import itertools

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from controller.superellipsoid import (
    DELTA,
    Q_MAX,
    closing_speed,
    plane_distance,
    superellipsoid_mesh,
    support,
    support_point,
)

RNG = np.random.default_rng(11)
EPS_GRID = (0.1, 0.5, 1.0, 1.9)
SMOOTHING = 3 * DELTA  # m, the module's bound on h_smoothed - h (q below Q_MAX)


def implicit(semi_axes: np.ndarray, eps1: float, eps2: float, x: np.ndarray) -> np.ndarray:
    """The paper's eq. (superellipsoid_surface), left-hand side; 1 on the surface."""
    a, b, c = semi_axes
    xy = np.abs(x[..., 0] / a) ** (2 / eps1) + np.abs(x[..., 1] / b) ** (2 / eps1)
    return xy ** (eps1 / eps2) + np.abs(x[..., 2] / c) ** (2 / eps2)


def random_unit(n: int) -> np.ndarray:
    u = RNG.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def random_case() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Semi-axes 0.02..0.5 m, a random centre within 1 m and a random rotation."""
    return RNG.uniform(0.02, 0.5, 3), RNG.uniform(-1.0, 1.0, 3), Rotation.random(random_state=RNG).as_matrix()


@pytest.mark.parametrize(("eps1", "eps2"), [*itertools.product((0.1, 1.0, 1.9, 2.0), repeat=2), (0.3, 1.4)])
def test_mesh_vertices_satisfy_the_implicit_equation(eps1: float, eps2: float) -> None:
    """Every vertex of the parametric mesh lies on the implicit surface to 1e-9 (round-off of powers up to 20 is
    ~1e-13), and the mesh is a closed, outward-wound volume."""
    semi_axes = np.array([0.3, 0.05, 0.12])
    mesh = superellipsoid_mesh(semi_axes, eps1, eps2, resolution=64)
    np.testing.assert_allclose(implicit(semi_axes, eps1, eps2, mesh.vertices), 1.0, atol=1e-9)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.is_volume and mesh.volume > 0


def test_ellipsoid_mesh_volume() -> None:
    """eps1 = eps2 = 1 meshes an ellipsoid: volume 4/3 pi abc within 0.1 % (inscribed polytope, 256 segments)."""
    semi_axes = np.array([0.4, 0.1, 0.25])
    mesh = superellipsoid_mesh(semi_axes, 1.0, 1.0, resolution=256)
    assert mesh.volume == pytest.approx(4 / 3 * np.pi * np.prod(semi_axes), rel=1e-3)


def test_plane_distance_matches_a_fine_mesh() -> None:
    """Signed distance within 1 mm of the distance of a 256-segment mesh to the plane, for random poses and planes
    (semi-axes 0.02..0.5 m, eps over [0.1, 1.9] with both ends), many of them penetrated (negative distance).

    Oracle: min over the trimesh vertices (world pose applied by trimesh) of n.x + D, exact for the convex
    polytope they span. That polytope is inscribed, so the mesh distance can only exceed the true one, by a
    second-order error ~ 8 a_max / resolution^2 (measured 0.26 mm at 128 and 0.06 mm at 256 segments on 0.5 m
    semi-axes; 64 segments is the coarsest for 1 mm). The smoothing makes the formula's distance smaller still, by
    <= 3 DELTA. So the check is one-sided: 0 <= d_mesh - d <= 1 mm.
    """
    eps_values = [*itertools.product((0.1, 1.9), repeat=2), *RNG.uniform(0.1, 1.9, (30, 2))]
    gaps, distances = [], []
    for eps1, eps2 in eps_values:
        semi_axes, center, R = random_case()
        mesh = superellipsoid_mesh(semi_axes, eps1, eps2, resolution=256)
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = R, center
        mesh.apply_transform(pose)
        for n in random_unit(3):
            offset = -n @ center + RNG.uniform(-1.2, 1.2) * semi_axes.max()
            d_mesh = float(np.min(mesh.vertices @ n + offset))
            d = plane_distance(semi_axes, eps1, eps2, center, R, n, offset)
            gaps.append(d_mesh - d)
            distances.append(d)
    gaps = np.array(gaps)
    assert gaps.min() >= -1e-12, "the formula's distance exceeds the inscribed mesh's"
    assert gaps.max() <= 1e-3
    assert np.sum(np.array(distances) < 0) >= 20, "too few penetrating planes to test"


@pytest.mark.parametrize(("eps1", "eps2"), [(0.1, 0.1), (1.9, 1.9), (0.1, 1.9), (1.0, 0.4), (0.7, 1.3)])
def test_closing_speed_is_the_time_derivative_of_the_distance(eps1: float, eps2: float) -> None:
    """Along a rigid motion c(t) = c0 + v t, R(t) = R0 exp(t [omega]x) (body-frame omega, scipy's rotation
    vector), the closing speed equals a central difference of plane_distance to 1e-6 relative: step 1e-5 s gives
    truncation ~ (1e-5)^2 |d'''| ~ 1e-10 m/s and round-off ~ 1e-16 / 1e-5 = 1e-11 m/s."""
    dt = 1e-5
    for _ in range(20):
        semi_axes, center, R0 = random_case()
        n, v, omega = random_unit(1)[0], RNG.normal(0, 0.5, 3), RNG.normal(0, 1.0, 3)
        offset = -n @ center + RNG.uniform(-1, 1)

        def dist(t: float, semi_axes=semi_axes, center=center, R0=R0, n=n, v=v, omega=omega, offset=offset) -> float:
            R = R0 @ Rotation.from_rotvec(omega * t).as_matrix()
            return plane_distance(semi_axes, eps1, eps2, center + v * t, R, n, offset)

        fd = (dist(dt) - dist(-dt)) / (2 * dt)
        rate = closing_speed(semi_axes, eps1, eps2, R0, n, v, omega)
        assert rate == pytest.approx(fd, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize(("eps1", "eps2"), list(itertools.product((0.1, 1.0, 1.9, 2.0), repeat=2)))
def test_axis_directions_are_finite_and_exact(eps1: float, eps2: float) -> None:
    """For u exactly along +-x, +-y, +-z (where |w| is 0 in two components) and eps at 0.1, 1, 1.9, 2: the support
    equals that semi-axis (within the smoothing and the Q_MAX cap, whose relative bound is 2^(2/Q_MAX) - 1), and
    the CasADi gradient and Hessian with respect to u and both eps are finite."""
    semi_axes = np.array([0.5, 0.02, 0.2])
    u, e = ca.SX.sym("u", 3), ca.SX.sym("e", 2)
    h = support(semi_axes, e[0], e[1], u)
    x = ca.vertcat(u, e)
    f = ca.Function("f", [x], [h, ca.jacobian(h, x), ca.hessian(h, x)[0]])
    cap = 2 ** (2 / Q_MAX) - 1
    for axis, sign in itertools.product(range(3), (1.0, -1.0)):
        direction = np.zeros(3)
        direction[axis] = sign
        val, grad, hess = (np.asarray(o) for o in f(np.r_[direction, eps1, eps2]))
        assert np.all(np.isfinite(grad)) and np.all(np.isfinite(hess))
        assert semi_axes[axis] <= val.item() <= semi_axes[axis] * (1 + cap) + SMOOTHING


def test_ellipsoid_and_sphere_closed_forms() -> None:
    """eps1 = eps2 = 1 is the ellipsoid, support |diag(a,b,c) u| and farthest point diag(a,b,c)^2 u / h; a sphere
    of radius r is at distance n.c + D - r from any plane. Tolerance: the smoothing bound 3 DELTA (3e-7 m) on h,
    and 1e-5 relative on the point (the smoothing's relative error on the 0.02..0.5 m semi-axes)."""
    for u in random_unit(50):
        semi_axes = RNG.uniform(0.02, 0.5, 3)
        h_ref = np.linalg.norm(semi_axes * u)
        assert 0 <= support(semi_axes, 1.0, 1.0, u) - h_ref <= SMOOTHING
        np.testing.assert_allclose(support_point(semi_axes, 1.0, 1.0, u), semi_axes**2 * u / h_ref, rtol=1e-5)
    for _ in range(20):
        r, (_, center, R) = RNG.uniform(0.01, 0.5), random_case()
        n, offset = random_unit(1)[0], RNG.uniform(-2, 2)
        d = plane_distance(np.full(3, r), 1.0, 1.0, center, R, n, offset)
        assert n @ center + offset - r - SMOOTHING <= d <= n @ center + offset - r


def test_octahedron_at_eps_two() -> None:
    """eps1 = eps2 = 2 is the octahedron |x/a| + |y/b| + |z/c| <= 1, support max(a|u_x|, b|u_y|, c|u_z|): reached
    through the Q_MAX cap, from above, within the cap's relative bound 2^(2/Q_MAX) - 1 = 1.4e-4."""
    cap = 2 ** (2 / Q_MAX) - 1
    for u in random_unit(50):
        semi_axes = RNG.uniform(0.02, 0.5, 3)
        h_ref = np.max(semi_axes * np.abs(u))
        assert h_ref <= support(semi_axes, 2.0, 2.0, u) <= h_ref * (1 + cap) + SMOOTHING


@pytest.mark.parametrize(("eps1", "eps2"), [(0.1, 0.1), (0.1, 1.9), (1.9, 0.1), (0.6, 1.2)])
def test_support_point_is_the_farthest_surface_point(eps1: float, eps2: float) -> None:
    """grad h(u) lies on the implicit surface (to 1e-4: the smoothing's relative error, amplified by exponents up
    to 2/eps = 20), u . grad h = h (Euler, h is 1-homogeneous; to 3 DELTA) and no vertex of a 128-segment mesh
    lies farther along u (mesh inscribed)."""
    semi_axes = np.array([0.3, 0.15, 0.45])
    mesh = superellipsoid_mesh(semi_axes, eps1, eps2, resolution=128)
    for u in random_unit(30):
        p, h = support_point(semi_axes, eps1, eps2, u), support(semi_axes, eps1, eps2, u)
        assert implicit(semi_axes, eps1, eps2, p) == pytest.approx(1.0, abs=1e-4)
        assert u @ p == pytest.approx(h, abs=SMOOTHING)
        assert np.max(mesh.vertices @ u) <= h


def test_symbolic_sx_and_mx_agree_with_numpy() -> None:
    """The same formula inside OCP graphs: SX and MX expressions of plane_distance and closing_speed, with the
    pose, the plane and the velocities symbolic, evaluate to the numpy values (to round-off, 1e-12 m)."""
    semi_axes, center, R = random_case()
    n, offset, v, omega = random_unit(1)[0], 0.3, RNG.normal(size=3), RNG.normal(size=3)
    ref = (plane_distance(semi_axes, 0.3, 1.6, center, R, n, offset),
           closing_speed(semi_axes, 0.3, 1.6, R, n, v, omega))
    for sym in (ca.SX, ca.MX):
        c, Rs, ns, vs, ws = sym.sym("c", 3), sym.sym("R", 3, 3), sym.sym("n", 3), sym.sym("v", 3), sym.sym("w", 3)
        f = ca.Function("f", [c, Rs, ns, vs, ws], [plane_distance(semi_axes, 0.3, 1.6, c, Rs, ns, offset),
                                                   closing_speed(semi_axes, 0.3, 1.6, Rs, ns, vs, ws)])
        out = f(center, R, n, v, omega)
        np.testing.assert_allclose([float(o) for o in out], ref, atol=1e-12)


def test_bad_parameters_raise() -> None:
    """Numeric exponents outside (0, 2] or non-positive semi-axes are refused, naming the argument."""
    with pytest.raises(ValueError, match="eps1"):
        support([0.1, 0.1, 0.1], 0.0, 1.0, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="eps2"):
        superellipsoid_mesh([0.1, 0.1, 0.1], 1.0, 2.5)
    with pytest.raises(ValueError, match="semi_axes"):
        plane_distance([0.1, -0.1, 0.1], 1.0, 1.0, np.zeros(3), np.eye(3), [0.0, 0.0, 1.0], 0.0)
    with pytest.raises(ValueError, match="smoothing"):
        support([0.1, 0.1, 0.1], 1.0, 1.0, [1.0, 0.0, 0.0], smoothing=0.0)


def exact_support(semi_axes: np.ndarray, eps1: float, eps2: float, u: np.ndarray) -> np.ndarray:
    """The dual nested norm without smoothing (closed form; the module's docstring), rows of u."""
    q2, q1 = 2 / (2 - eps1), 2 / (2 - eps2)
    w = np.abs(semi_axes * u)
    return ((w[:, 0] ** q2 + w[:, 1] ** q2) ** (q1 / q2) + w[:, 2] ** q1) ** (1 / q1)


@pytest.mark.parametrize("smoothing", [1e-4, 1e-3])
def test_smoothing_errs_on_the_safe_side_within_three_lengths(params, smoothing: float) -> None:
    """With a smoothing length s the support function overestimates the exact one (closed form) by 0 to 3 s, on
    random and axis directions (where the smoothing acts most) for the exponent grid (below 1.9: the Q_MAX cap is
    not at stake) and random semi-axes; for the default vehicle's bodies at s = 1e-3 m by at most 0.9 mm (the
    figure controller.model.ModelOptions.support_smoothing quotes). Tolerance 1e-12 m: round-off."""
    u = np.vstack([random_unit(500), np.eye(3), -np.eye(3), [[1.0, 1e-9, 0.0]]])
    cases = [(RNG.uniform(0.02, 0.5, 3), e1, e2) for e1, e2 in itertools.product((0.1, 0.5, 1.0, 1.5), repeat=2)]
    for semi_axes, e1, e2 in cases:
        over = np.array([support(semi_axes, e1, e2, x, smoothing=smoothing) for x in u]) - exact_support(
            semi_axes, e1, e2, u)
        assert over.min() >= -1e-12 and over.max() <= 3 * smoothing + 1e-12
    if smoothing == 1e-3:
        shapes = [params.hull.superellipsoid] + [lk.superellipsoid for lk in params.arm.links]
        worst = max(float(np.max(np.array([support(se.semi_axes, se.eps1, se.eps2, x, smoothing=smoothing) for x in u])
                                 - exact_support(np.asarray(se.semi_axes), se.eps1, se.eps2, u))) for se in shapes)
        assert worst <= 0.9e-3


@pytest.mark.parametrize("smoothing", [DELTA, 1e-4, 1e-3])
def test_smoothing_sets_the_curvature_of_a_face_parallel_to_the_plane(params, smoothing: float) -> None:
    """The default hull (eps1 = 0.4: q = 1.25) facing a wall, yawed by psi: near psi = 0 the distance is
    a - (b |psi|)^q / (q a^(q-1)) to leading order, |b psi| smoothed to sqrt(b^2 psi^2 + s^2), so d''(0) =
    -b^2 s^(q-2) / a^(q-1): about -2.1e4 m/rad^2 at the default s = 1e-7 m and -21 m/rad^2 at 1e-3 m. Central finite
    differences with a step of s / (100 b) (inside the smoothed region) against that; tolerance 2 %: the
    leading-order expansion's error at s = 1e-3 m (1.1 %) and the other terms' smoothing."""
    se = params.hull.superellipsoid
    a, b = se.semi_axes[:2]
    q = 2 / (2 - se.eps1)

    def d(psi: float) -> float:
        R = Rotation.from_euler("z", psi).as_matrix()
        return plane_distance(se.semi_axes, se.eps1, se.eps2, np.zeros(3), R, [-1.0, 0.0, 0.0], 1.0,
                              smoothing=smoothing)

    k = 1e-2 * smoothing / b
    curvature = (d(k) - 2 * d(0.0) + d(-k)) / k**2
    assert curvature == pytest.approx(-b**2 * smoothing ** (q - 2) / a ** (q - 1), rel=0.02)
