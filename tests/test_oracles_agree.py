"""The two rigid-body oracles (tests/oracles/rigid_body.py: Pinocchio and the project's MuJoCo plant
with fluid, buoyancy and added mass off) agree with each other, with the paper's kinematics, and with a
third, library-free computation of M and b (Kane's equations with momenta differentiated numerically).

Everything is in the paper's coordinates: h = [x y z phi theta psi q_m | v omega qdot_m],
nu = [v_body, omega_body, qdot_m], M(q) nu_dot + b(q, nu) = tau.
"""

from __future__ import annotations

from functools import partial

import mujoco
import numpy as np
import pinocchio as pin
import pytest
from oracles.rigid_body import (
    GRAVITY,
    MujocoOracle,
    PinocchioOracle,
    free_joint_map,
    free_joint_map_rate,
    split_state,
)

from uvms import load_params
from uvms.conventions import state_to_mujoco
from uvms.params import UVMSParams
from uvms.scene import Scene

ARMS = ("alpha3", "alpha4", "alpha6")
N_STATES = 100
THETA_MAX = np.deg2rad(75.0)  # rad: sampled pitch stays 15 deg away from the Euler singularity


# ---------------------------------------------------------------------------------------------
# Sampling and small helpers


def random_state(p: UVMSParams, rng: np.random.Generator) -> np.ndarray:
    """A random paper state: position in a 10 m box, any roll and yaw, |pitch| <= 75 deg, joint angles
    uniform in their ranges, body velocities ~ N(0, 0.5 m/s), rates ~ N(0, 1 rad/s), joint rates
    ~ N(0, 1.5 rad/s) (so Coriolis terms are of the same order as gravity in b)."""
    lo = np.array([lk.joint_range[0] for lk in p.arm.links])
    hi = np.array([lk.joint_range[1] for lk in p.arm.links])
    return np.concatenate([
        rng.uniform(-5.0, 5.0, 3),
        [rng.uniform(-np.pi, np.pi), rng.uniform(-THETA_MAX, THETA_MAX), rng.uniform(-np.pi, np.pi)],
        rng.uniform(lo, hi),
        rng.normal(0.0, 0.5, 3), rng.normal(0.0, 1.0, 3), rng.normal(0.0, 1.5, p.n_joints),
    ])


def states(arm: str, seed: int) -> tuple[UVMSParams, list[np.ndarray]]:
    p = load_params(arm=arm)
    rng = np.random.default_rng(seed)
    return p, [random_state(p, rng) for _ in range(N_STATES)]


def rel(a: np.ndarray, b: np.ndarray) -> float:
    """|a - b| / |a| (Frobenius norm for matrices)."""
    return float(np.linalg.norm(a - b) / np.linalg.norm(a))


def skew(r: np.ndarray) -> np.ndarray:
    """S(r) with S(r) x = r x x."""
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def vee(S: np.ndarray) -> np.ndarray:
    """The vector of the skew-symmetric part of S."""
    A = 0.5 * (S - S.T)
    return np.array([A[2, 1], A[0, 2], A[1, 0]])


def d_dt(f, eps: float = 3e-4) -> np.ndarray:
    """f'(0) by the fourth-order central stencil: truncation eps^4 |f^(5)| / 30, rounding ~ 1e-16 |f| / eps.

    With joint rates of a few rad/s chained through six links, |f^(5)| / |f'| reaches ~1e4 s^-4, so the
    truncation is ~1e-12 relative at eps = 3e-4 s and the rounding ~3e-13 (measured: 1e-9 at eps = 1e-3,
    ~1e-11 at 3e-4, 1e-4 and 3e-5: the eps^4 law, then rounding)."""
    return (f(-2 * eps) - 8 * f(-eps) + 8 * f(eps) - f(2 * eps)) / (12 * eps)


# ---------------------------------------------------------------------------------------------
# A third reference, numpy only: kinematics from the parameter file's conventions, and Kane's equations.


def rot_axis(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: rotation by `angle` [rad] about the unit `axis`."""
    K = skew(axis)
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


def rot_zyx(phi: float, theta: float, psi: float) -> np.ndarray:
    """Rz(psi) Ry(theta) Rx(phi) from the three elementary rotations."""
    return rot_axis(np.array([0.0, 0, 1]), psi) @ rot_axis(np.array([0.0, 1, 0]), theta) \
        @ rot_axis(np.array([1.0, 0, 0]), phi)


def euler_rates(eul: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """ZYX Euler-angle rates [rad/s] of the body angular velocity omega [rad/s] (Fossen's T(Theta))."""
    f, t = eul[0], eul[1]
    sf, cf, ct, tt = np.sin(f), np.cos(f), np.cos(t), np.tan(t)
    T = np.array([[1.0, sf * tt, cf * tt], [0.0, cf, -sf], [0.0, sf / ct, cf / ct]])
    return T @ omega


def frames(p: UVMSParams, h: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """World (origin, rotation, origin velocity, angular velocity) of the hull and of every link frame,
    by the recursion the parameter file describes."""
    pos, eul, qm, nu = split_state(h, p.n_joints)
    R = rot_zyx(*eul)
    out = [(pos, R, R @ nu[0:3], R @ nu[3:6])]
    offset = np.asarray(p.hull.arm_mount, float)
    for lk, q, qd in zip(p.arm.links, qm, nu[6:], strict=True):
        o, Rp, vo, w = out[-1]
        r = Rp @ offset
        Ri = Rp @ rot_axis(np.asarray(lk.joint_axis, float), q)
        out.append((o + r, Ri, vo + np.cross(w, r), w + Ri @ lk.joint_axis * qd))
        offset = np.array([lk.length, 0.0, 0.0])
    return out


def bodies(p: UVMSParams, h: np.ndarray) -> list[tuple[float, np.ndarray, np.ndarray, np.ndarray]]:
    """(mass [kg], world CoM velocity [m/s], world angular velocity [rad/s], world inertia about the CoM
    [kg m^2]) of the hull and of every link."""
    inertial = [(p.hull.mass, p.hull.com, np.asarray(p.hull.inertia))]
    inertial += [(lk.mass, lk.com, np.diag(lk.inertia)) for lk in p.arm.links]
    out = []
    for (_, R, vo, w), (m, c, inertia) in zip(frames(p, h), inertial, strict=True):
        out.append((m, vo + np.cross(w, R @ c), w, R @ inertia @ R.T))
    return out


def kane(p: UVMSParams, h: np.ndarray, g: float) -> tuple[np.ndarray, np.ndarray]:
    """M and b from Kane's equations, sum_i (dv_ci/dnu)^T (m_i a_ci - m_i g) + (dw_i/dnu)^T dH_i/dt = tau,
    with the partial velocities exact (the velocities are linear in nu) and, at nu_dot = 0, the momenta
    m_i v_ci and H_i = I_i w_i (about the CoM, world frame) differentiated along hdot =
    [R v, T(Theta) omega, qdot_m, 0] by a fourth-order stencil. The rotor armature adds diag(rotor_inertia)
    to M and nothing to b (as in MuJoCo and Pinocchio)."""
    n = 6 + p.n_joints
    unit = [bodies(p, np.concatenate([h[:n], e])) for e in np.eye(n)]  # [k][i]: body i at nu = e_k
    Jv = [np.column_stack([unit[k][i][1] for k in range(n)]) for i in range(n - 5)]  # (3, n) per body
    Jw = [np.column_stack([unit[k][i][2] for k in range(n)]) for i in range(n - 5)]
    here = bodies(p, h)
    masses = [m for m, *_ in here]
    M = sum(m * jv.T @ jv + jw.T @ inertia @ jw
            for m, jv, jw, (_, _, _, inertia) in zip(masses, Jv, Jw, here, strict=True))
    M = M + np.diag(np.r_[np.zeros(6), [lk.rotor_inertia for lk in p.arm.links]])
    _, eul, _, nu = split_state(h, p.n_joints)
    hdot = np.concatenate([rot_zyx(*eul) @ nu[0:3], euler_rates(eul, nu[3:6]), nu[6:], np.zeros(n)])

    def momenta(t: float) -> np.ndarray:
        return np.array([np.r_[m * vc, inertia @ w] for m, vc, w, inertia in bodies(p, h + t * hdot)])

    rates = d_dt(momenta)  # (bodies, 6): dL/dt, dH/dt
    gvec = np.array([0.0, 0.0, -g])
    b = sum(jv.T @ (r[0:3] - m * gvec) + jw.T @ r[3:6] for m, jv, jw, r in zip(masses, Jv, Jw, rates, strict=True))
    return M, b


def pinocchio_motion(po: PinocchioOracle, h: np.ndarray, t: float) -> np.ndarray:
    """[hull position, hull rotation (9), q_m, EE position, EE rotation (9)] after Pinocchio's
    integrate(q, t nu) from the configuration of h (t [s])."""
    nu = split_state(h, po.n_joints)[3]
    q = pin.integrate(po.model, po.configuration(h), t * nu)
    pin.framesForwardKinematics(po.model, po.data, q)
    base, ee = po.data.oMi[1], po.data.oMf[po.ee_frame]
    return np.concatenate([base.translation, base.rotation.ravel(), q[7:], ee.translation, ee.rotation.ravel()])


def mujoco_motion(mo: MujocoOracle, h: np.ndarray, t: float) -> np.ndarray:
    """The same after MuJoCo's mj_integratePos(qpos, qvel, t) from (qpos, qvel) = state_to_mujoco(h)."""
    qpos, qvel = state_to_mujoco(h, mo.n_joints)
    mujoco.mj_integratePos(mo.model, qpos, qvel, t)
    mo.data.qpos[:] = qpos
    mujoco.mj_kinematics(mo.model, mo.data)
    base, ee_body, d = mo.bodies[0], mo.bodies[-1], mo.data
    return np.concatenate([d.xpos[base], d.xmat[base], qpos[7:], d.site_xpos[mo.ee_site], d.xmat[ee_body]])


# ---------------------------------------------------------------------------------------------
# Fixtures


@pytest.fixture(scope="module", params=ARMS)
def arm(request: pytest.FixtureRequest) -> str:
    return request.param


# ---------------------------------------------------------------------------------------------
# Tests


def test_pinocchio_and_mujoco_agree(arm: str, scene: Scene) -> None:
    """Over 100 random states per arm, Pinocchio and the mapped MuJoCo plant agree on M and b (with
    gravity, and with g = 0 so that the Coriolis/centrifugal part is compared on its own) to 1e-8
    relative to the norm of Pinocchio's matrix/vector, and on FK (every link frame and the EE point) and
    the EE Jacobian to 1e-10 absolute (m, -, m and rad per unit nu).

    Both are exact O(n) / O(n^2) recursions in double precision on quantities of order 1 to 100, so
    they differ by rounding only (measured about 1e-15 relative); 1e-8 and 1e-10 leave room for the
    conditioning of different recursions while any modelling or mapping error (a missed Tdot nu term,
    an inertia about the wrong point, a wrong axis) shows at 1e-3 or more (see the control test).
    """
    p, hs = states(arm, seed=1)
    pg, mg = PinocchioOracle(p, GRAVITY), MujocoOracle(p, scene, GRAVITY)
    p0, m0 = PinocchioOracle(p, 0.0), MujocoOracle(p, scene, 0.0)
    worst = dict(M=0.0, b=0.0, b_coriolis=0.0, fk=0.0, J=0.0)
    for h in hs:
        worst["M"] = max(worst["M"], rel(pg.mass_matrix(h), mg.mass_matrix(h)))
        worst["b"] = max(worst["b"], rel(pg.bias(h), mg.bias(h)))
        worst["b_coriolis"] = max(worst["b_coriolis"], rel(p0.bias(h), m0.bias(h)))
        a, c = pg.poses(h), mg.poses(h)
        worst["fk"] = max(worst["fk"], *(float(np.max(np.abs(x - y))) for x, y in [
            (a.positions, c.positions), (a.rotations, c.rotations),
            (a.ee_position, c.ee_position), (a.ee_rotation, c.ee_rotation)]))
        worst["J"] = max(worst["J"], float(np.max(np.abs(pg.ee_jacobian(h) - mg.ee_jacobian(h)))))
    print(f"{arm}: worst {worst}")
    assert worst["M"] < 1e-8 and worst["b"] < 1e-8 and worst["b_coriolis"] < 1e-8, worst
    assert worst["fk"] < 1e-10 and worst["J"] < 1e-10, worst


def test_kane_finite_differences_agree(arm: str, scene: Scene) -> None:
    """An independent check of M and b: Kane's equations written from the parameter file alone (numpy
    kinematics, exact partial velocities, momenta differentiated along the motion at nu_dot = 0 by a
    fourth-order stencil of step 3e-4 s, `d_dt`), over 30 random states per arm, with g = 9.81 and
    g = 0 (Coriolis/centrifugal terms alone).

    It shares no code with Pinocchio or MuJoCo and uses neither the quaternion nor the free-joint maps:
    the attitude moves through the ZYX Euler-rate map. It also checks the numpy FK against both oracles
    (1e-12 m and -, rounding only). Tolerances: M to 1e-12 relative (no differentiation, rounding
    only: measured ~1e-15); b to 1e-9 relative (the stencil's error is ~1e-11 relative, measured
    < 1e-11; adding 1e-6 kg m^2, 2 % of its Izz, to the last link of alpha6 moves b by 1.5e-7).
    """
    p = load_params(arm=arm)
    rng = np.random.default_rng(2)
    oracles = {g: (PinocchioOracle(p, g), MujocoOracle(p, scene, g)) for g in (GRAVITY, 0.0)}
    worst = dict(M=0.0, b=0.0, fk=0.0)
    for _ in range(30):
        h = random_state(p, rng)
        fr = frames(p, h)
        for oracle in oracles[GRAVITY]:
            ps = oracle.poses(h)
            worst["fk"] = max(worst["fk"], float(np.max(np.abs(ps.positions - [f[0] for f in fr]))),
                              float(np.max(np.abs(ps.rotations - [f[1] for f in fr]))),
                              float(np.max(np.abs(ps.ee_position - fr[-1][0] - fr[-1][1] @ p.arm.end_effector))))
        for g, pair in oracles.items():
            M, b = kane(p, h, g)
            for oracle in pair:
                worst["M"] = max(worst["M"], rel(M, oracle.mass_matrix(h)))
                worst["b"] = max(worst["b"], rel(b, oracle.bias(h)))
    print(f"{arm}: worst {worst}")
    assert worst["M"] < 1e-12 and worst["b"] < 1e-9 and worst["fk"] < 1e-12, worst


def test_velocity_conventions(arm: str, scene: Scene) -> None:
    """Each library's own velocity convention is what the oracle assumes: moving the configuration
    with Pinocchio's `integrate(q, t nu)` and with MuJoCo's `mj_integratePos(qpos, T nu, t)` gives, at
    t = 0, hull velocity pdot = R v, Rdot = R S(omega), joint rates qdot_m, and an EE velocity equal to
    J nu (linear: d/dt of the EE point; angular: vee(Rdot_ee R_ee^T)). So Pinocchio's free-flyer
    velocity is exactly [v_body, omega_body] and MuJoCo's is [R v, omega_body]. 20 states per arm;
    derivatives by `d_dt` (step 3e-4 s): 1e-9 absolute (m/s, rad/s; the stencil's error is ~1e-11,
    measured < 1e-11; swapping body and world velocity would err by ~|v| ~ 1)."""
    p = load_params(arm=arm)
    rng = np.random.default_rng(3)
    po, mo = PinocchioOracle(p), MujocoOracle(p, scene)
    n = 6 + p.n_joints
    worst = 0.0
    for _ in range(20):
        h = random_state(p, rng)
        _, eul, _, nu = split_state(h, p.n_joints)
        R = rot_zyx(*eul)
        expect = np.concatenate([R @ nu[0:3], R @ nu[3:6], nu[6:]])  # pdot, world omega, qdot_m
        ee_expect = po.ee_jacobian(h) @ nu

        k = 12 + p.n_joints  # layout: base position, base rotation, q_m, then (k:) EE position, EE rotation
        for motion in (partial(pinocchio_motion, po, h), partial(mujoco_motion, mo, h)):
            at0, rate = motion(0.0), d_dt(motion)
            Rb, Re = at0[3:12].reshape(3, 3), at0[k + 3:k + 12].reshape(3, 3)
            got = np.concatenate([rate[0:3], vee(rate[3:12].reshape(3, 3) @ Rb.T), rate[12:k]])
            got_ee = np.concatenate([rate[k:k + 3], vee(rate[k + 3:k + 12].reshape(3, 3) @ Re.T)])
            assert got.shape == (n,)
            worst = max(worst, float(np.max(np.abs(got - expect))), float(np.max(np.abs(got_ee - ee_expect))))
    print(f"{arm}: worst {worst:.3g}")
    assert worst < 1e-9


def test_control_naive_mappings_fail(scene: Scene) -> None:
    """Control: the comparison can fail. Taking MuJoCo's M and qfrc_bias as if qvel were nu, or
    leaving out the Tdot nu term, disagrees with Pinocchio by far more than 1e-8 (here > 1e-3 relative
    on at least one of 10 states), so the agreement above is not an artefact of the mapping."""
    p = load_params(arm="alpha4")
    rng = np.random.default_rng(4)
    po, mo = PinocchioOracle(p), MujocoOracle(p, scene)
    no_T, no_Tdot = 0.0, 0.0
    for _ in range(10):
        h = random_state(p, rng)
        M_mj = mo.mass_matrix_mujoco(h)
        R = mo.data.xmat[mo.bodies[0]].reshape(3, 3)
        T = free_joint_map(R, p.n_joints)
        no_T = max(no_T, rel(po.mass_matrix(h), M_mj), rel(po.bias(h), mo.data.qfrc_bias))
        no_Tdot = max(no_Tdot, rel(po.bias(h), T.T @ mo.data.qfrc_bias))
        assert rel(po.bias(h), T.T @ (M_mj @ free_joint_map_rate(R, split_state(h, p.n_joints)[3])
                                      + mo.data.qfrc_bias)) < 1e-8
    assert no_T > 1e-3 and no_Tdot > 1e-3, (no_T, no_Tdot)


def test_unaligned_revolute_joints_agree(arm: str) -> None:
    """Pinocchio with JointModelRevoluteUnaligned on every joint gives the same M, b and J as with
    RX/RY/RZ (1e-12 relative / absolute: the same recursion up to the rotation formula's rounding),
    so the oracle does not depend on which joint type represents an axis."""
    p, hs = states(arm, seed=5)
    a, u = PinocchioOracle(p, aligned=True), PinocchioOracle(p, aligned=False)
    assert all(j.shortname() == "JointModelRevoluteUnaligned" for j in list(u.model.joints)[2:])
    for h in hs[:10]:
        assert rel(a.mass_matrix(h), u.mass_matrix(h)) < 1e-12
        assert rel(a.bias(h), u.bias(h)) < 1e-12
        assert np.max(np.abs(a.ee_jacobian(h) - u.ee_jacobian(h))) < 1e-12
