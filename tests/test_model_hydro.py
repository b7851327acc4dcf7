"""The paper's model, hull alone: each hydrodynamic and hydrostatic term against Fossen's closed
forms (Fossen 2011, Handbook of Marine Craft Hydrodynamics and Motion Control), and energy
conservation of the whole UVMS with its added mass."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import skew

from controller.model import TERMS, ModelError, ModelOptions, UVMSModel, water
from uvms.conventions import euler_zyx_to_matrix

RNG = np.random.default_rng(21)


@pytest.fixture(scope="module")
def hull_model(params, scene):
    """The trimmed hull without its arm: CoG and CoB off the origin, so r_g and r_b terms count."""
    return UVMSModel(params.without_arm(), scene.water)


def random_hull_state() -> np.ndarray:
    h = np.zeros(12)
    h[:3], h[3:6] = RNG.normal(size=3), RNG.uniform(-1.2, 1.2, 3)
    h[6:9], h[9:12] = RNG.normal(0, 0.5, 3), RNG.normal(0, 0.8, 3)
    return h


def fossen_terms(p, water, h, vc, ac):
    """Fossen's closed forms for a 6-DOF body with diagonal M_A and D, current vc (world, constant
    or with acceleration ac): M_RB (eq. 3.44), C_RB (eq. 3.60), C_A (eq. 6.43), D (eq. 6.57 with a
    quadratic part), g(eta) (eq. 4.6, written z up), all about the body origin."""
    H = p.hull
    m, rg, rb = H.mass, H.com, H.cob
    I_o = H.inertia - m * skew(rg) @ skew(rg)
    M_RB = np.block([[m * np.eye(3), -m * skew(rg)], [m * skew(rg), I_o]])
    R = euler_zyx_to_matrix(*h[3:6])
    v, w = h[6:9], h[9:12]
    C_RB = np.block([[m * skew(w), -m * skew(w) @ skew(rg)], [m * skew(rg) @ skew(w), -skew(I_o @ w)]])
    vc_B, ac_B = R.T @ vc, R.T @ ac
    nu_r = np.concatenate([v - vc_B, w])
    A1, A2 = np.diag(H.added_mass[:3]), np.diag(H.added_mass[3:])
    C_A = np.block([[np.zeros((3, 3)), -skew(A1 @ nu_r[:3])], [-skew(A1 @ nu_r[:3]), -skew(A2 @ w)]])
    nu_c_dot = np.concatenate([-np.cross(w, vc_B) + ac_B, np.zeros(3)])  # d/dt of [R^T vc; 0]
    D = np.diag(H.linear_damping) + np.diag(H.quadratic_damping * np.abs(nu_r))
    W, B = m * water.gravity, water.density * H.volume * water.gravity
    f_g, f_b = R.T @ [0, 0, -W], R.T @ [0, 0, B]
    fk = water.density * H.volume * ac_B
    return {
        "M": M_RB + np.diag(H.added_mass),
        "coriolis": -C_RB @ h[6:12],
        "added_mass": np.diag(H.added_mass) @ nu_c_dot - C_A @ nu_r,
        "drag": -D @ nu_r,
        "gravity": np.concatenate([f_g, np.cross(rg, f_g)]),
        "buoyancy": np.concatenate([f_b, np.cross(rb, f_b)]),
        "froude_krylov": np.concatenate([fk, np.cross(rb, fk)]),
    }


@pytest.mark.parametrize("term", ["M", "coriolis", "added_mass", "drag", "gravity", "buoyancy", "froude_krylov"])
def test_hull_terms_equal_fossen_closed_forms(hull_model, params, scene, term) -> None:
    """50 random states and currents: each term equals its closed form to 1e-9 relative, except
    drag (1e-3: the model smooths |x| as sqrt(x^2 + (1e-4 m/s)^2) so that NLPs stay smooth)."""
    for _ in range(50):
        h = random_hull_state()
        vc, ac = RNG.normal(0, 0.3, 3), RNG.normal(0, 0.2, 3)
        ref = fossen_terms(params.without_arm(), scene.water, h, vc, ac)[term]
        if term == "M":
            got = np.asarray(hull_model.mass_matrix(h))
        else:
            out = hull_model.generalized_forces(h, np.zeros(8), np.zeros(6), np.eye(3), water(vc), ac)
            got = np.asarray(out[TERMS.index(term)]).ravel()
        tol = 1e-3 if term == "drag" else 1e-9
        np.testing.assert_allclose(got, ref, rtol=tol, atol=tol * np.abs(ref).max())


def energy(model: UVMSModel, p, water, h: np.ndarray) -> float:
    """Kinetic energy 1/2 nu^T M nu (rigid, rotor and added mass) plus the potential of gravity
    and buoyancy, sum m g z_CoM - rho V g z_CoB [J]."""
    n = p.n_joints
    nu = h[6 + n:]
    kinetic = 0.5 * nu @ np.asarray(model.mass_matrix(h)) @ nu
    R, x = euler_zyx_to_matrix(*h[3:6]), h[:3]
    poses = [np.asarray(a) for a in model.link_poses(h)]
    frames = [(x, R, p.hull)] + [(poses[k].ravel(), poses[n + k], p.arm.links[k]) for k in range(n)]
    g, rho = water.gravity, water.density
    potential = sum(b.mass * g * (o + Rk @ b.com)[2] - rho * b.volume * g * (o + Rk @ b.cob)[2] for o, Rk, b in frames)
    return kinetic + potential


@pytest.mark.slow
def test_energy_is_conserved_without_drag_inputs_or_current(params, scene) -> None:
    """No drag, no inputs, still water: the model is conservative (Kirchhoff added-mass terms do
    no work), so RK4 with dt = 1 ms keeps the total energy over 3 s of tumbling motion within
    1e-7 of the initial kinetic energy (RK4's error is O(dt^4)). Checked by mutation: dropping or
    flipping the rotating-frame term of the added mass, or scaling a body's inertia by 1.001 in M
    only, breaks it by 1e-1 to 1e-6; gyroscopic terms such as (A2 w) x w do no work, so only the
    closed-form test above can catch their sign."""
    model = UVMSModel(params, scene.water, ModelOptions(drag=False))
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[3:6] = [0.3, -0.2, 0.5]
    h[6:6 + n] = params.arm.home
    h[6 + n:] = RNG.normal(0, 0.5, 6 + n)
    e0, ke0 = energy(model, params, scene.water, h), 0.5 * h[6 + n:] @ np.asarray(model.mass_matrix(h)) @ h[6 + n:]
    u = np.zeros(params.n_inputs)
    step = model.rk4.map(1)
    for _ in range(3000):
        h = np.asarray(step(h, u, np.zeros(6), np.eye(3), water(), np.zeros(3), 1e-3)).ravel()
    assert abs(energy(model, params, scene.water, h) - e0) < 1e-7 * ke0


def test_bad_parameters_are_clear_model_errors(params, scene) -> None:
    link = params.arm.links[1]
    zero_length = dataclasses.replace(params, arm=dataclasses.replace(
        params.arm, links=(params.arm.links[0], dataclasses.replace(link, length=0.0), *params.arm.links[2:])))
    with pytest.raises(ModelError, match=r"length 0\.0 m; allowed: > 0"):
        UVMSModel(zero_length, scene.water)
    no_volume = dataclasses.replace(params, hull=dataclasses.replace(params.hull, volume=0.0))
    with pytest.raises(ModelError, match="no volume"):
        UVMSModel(no_volume, scene.water)
    singular = dataclasses.replace(params, hull=dataclasses.replace(params.hull, inertia=np.zeros((3, 3))))
    with pytest.raises(ModelError, match="singular"):
        UVMSModel(singular, scene.water)


def test_link_cross_flow_drag_and_added_mass_about_the_elbow(params, scene) -> None:
    """At home the elbow and wrist links form one straight cylinder of radius r and length L from
    the elbow axis, perpendicular to it. Spinning only the elbow at rate w in still water:
    cross-flow drag integrates to a joint torque -rho C_d r w|w| L^4 / 4 (three Gauss points are
    exact for this quartic), and the links' added mass adds sum m_t (d^2 + l^2/12) to M's elbow
    entry (m_t = C_a rho pi r^2 l, d the centre's distance from the axis). Added mass to 1e-9
    relative; drag to 1e-6 (the smooth |x| = sqrt(x^2 + (1e-4 m/s)^2) adds ~s^2 / 2 v^2 at the
    Gauss points, v = 0.06 to 0.5 m/s here: 4e-8 measured)."""
    n = params.n_joints
    elbow, wrist = params.arm.links[2], params.arm.links[3]
    rho, r, L = scene.water.density, elbow.radius, elbow.length + wrist.length
    assert wrist.radius == r and wrist.drag_coefficient == elbow.drag_coefficient
    h = np.zeros(params.n_states)
    h[6:6 + n] = params.arm.home
    w = 2.0
    h[6 + n + 6 + 2] = w
    full = UVMSModel(params, scene.water)
    drag = np.asarray(full.generalized_forces(h, np.zeros(params.n_inputs), np.zeros(6), np.eye(3),
                                              water(), np.zeros(3))[TERMS.index("drag")]).ravel()
    assert drag[6 + 2] == pytest.approx(-rho * elbow.drag_coefficient * r * w * abs(w) * L**4 / 4, rel=1e-6)
    no_added = UVMSModel(params, scene.water, ModelOptions(added_mass=False))
    I_A = sum(lk.added_mass_coefficient * rho * np.pi * lk.radius**2 * lk.length * (dk**2 + lk.length**2 / 12)
              for lk, dk in ((elbow, elbow.length / 2), (wrist, elbow.length + wrist.length / 2)))
    gain = np.asarray(full.mass_matrix(h))[8, 8] - np.asarray(no_added.mass_matrix(h))[8, 8]
    assert gain == pytest.approx(I_A, rel=1e-9)


def test_extra_hull_weight_is_the_gravity_of_a_heavier_hull(params, scene) -> None:
    """The 4th entry of the water input (controller.model.water: the hull's weight in water beyond
    its parameters', N) acts as the weight of W/g more hull mass at its CoM: at 20 random states of
    the whole UVMS, the gravity term with W = 30 N equals that of a model whose hull is W/g heavier
    (its parameters changed, its own gravity code) to 1e-9 relative (rounding of sums of ~100 N),
    and every other term is unchanged to the bit."""
    W, n = 30.0, params.n_joints
    model = UVMSModel(params, scene.water)
    heavy = UVMSModel(dataclasses.replace(params, hull=dataclasses.replace(
        params.hull, mass=params.hull.mass + W / scene.water.gravity)), scene.water)
    for _ in range(20):
        h = np.zeros(params.n_states)
        h[:3], h[3:6] = RNG.normal(size=3), RNG.uniform(-1.2, 1.2, 3)
        h[6:6 + n], h[6 + n:] = params.arm.home + RNG.normal(0, 0.3, n), RNG.normal(0, 0.4, 6 + n)
        u, vc = RNG.normal(0, 5, params.n_inputs), RNG.normal(0, 0.2, 3)
        args = (h, u, np.zeros(6), np.eye(3))
        with_w = model.generalized_forces(*args, water(vc, W), np.zeros(3))
        without = model.generalized_forces(*args, water(vc), np.zeros(3))
        ref = np.asarray(heavy.generalized_forces(*args, water(vc), np.zeros(3))[TERMS.index("gravity")]).ravel()
        for i, term in enumerate(TERMS):
            got = np.asarray(with_w[i]).ravel()
            if term == "gravity":
                np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
            else:
                np.testing.assert_array_equal(got, np.asarray(without[i]).ravel())
