"""Mode III (paper Sec. IV-C): Algorithm 2's pieces against closed forms, and one solve checked for
contact, the friction law and its effect on the hull against a coasting rollout of the model."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from controller.mode1 import SolverStatus
from controller.mode3 import ModeIIIOCP, ModeIIISettings
from controller.model import UVMSModel
from controller.rollouts import ReachPosture
from controller.transcription import tip_gap
from validation.closed_loop import initial_state
from validation.scenarios import wall_approach


@pytest.fixture(scope="module")
def contact_case(params, scene):
    """Thrusters dead, hull 0.35 m from the wall approaching at 0.3 m/s, tip on the wall."""
    model = UVMSModel(params, scene.water)
    ocp = ModeIIIOCP(model, scene.planes, 0, ModeIIISettings())
    lo, hi = params.input_bounds()
    lo[:8] = hi[:8] = 0.0
    ocp.limit_inputs(lo, hi)
    h, _ = initial_state(params, wall_approach(0.35, 0.3))
    n = params.n_joints
    h[6:6 + n] = ReachPosture(model, scene.planes[0])(h)
    h[6:6 + n] = ocp.onto_plane(h)
    return model, ocp, h


def test_wall_inverse_kinematics_is_the_nearest_posture_on_the_plane(contact_case, scene) -> None:
    """Eq. Wall_InvKin from a posture 5 cm off the plane: the result puts the tip on the plane
    (1e-9 m), and the change in q is parallel to the constraint's gradient at the result, taken by
    central finite differences of the tip's gap (the first-order optimality condition of
    min |q - q0|^2 s.t. gap(q) = 0; 1e-6 of |dq| off it: the differences' truncation and rounding
    at a 1e-6 rad step)."""
    model, ocp, h = contact_case
    wall, n = scene.planes[0], model.n_joints
    h0 = h.copy()
    h0[0] -= 0.05
    q = ocp.onto_plane(h0)
    h1 = h0.copy()
    h1[6:6 + n] = q
    assert abs(float(tip_gap(model, h1, wall))) < 1e-9
    g = np.zeros(n)
    for j in range(n):
        hp, hm = h1.copy(), h1.copy()
        hp[6 + j] += 1e-6
        hm[6 + j] -= 1e-6
        g[j] = (float(tip_gap(model, hp, wall)) - float(tip_gap(model, hm, wall))) / 2e-6
    dq = q - h0[6:6 + n]
    off = dq - g * (g @ dq) / (g @ g)
    assert np.linalg.norm(off) < 1e-6 * np.linalg.norm(dq)


def test_pushing_force_saturates_a_joint(contact_case, params) -> None:
    """Eq. Fc_Init_OptProblem: at the returned normal force the static joint torques J_m^T n F_n
    reach the torque limit at one joint and stay within it at every joint (or the jaws' force
    limit binds)."""
    model, ocp, h = contact_case
    F = ocp.pushing_force(h)
    Jm = np.asarray(model.jacobian_ee(h))[:3, 6:]
    tau = np.abs(Jm.T @ ocp.Rw[:, 0]) * F
    limits = params.input_bounds()[1][params.n_thrusters:]
    assert np.all(tau <= limits * (1 + 1e-9))
    assert np.max(tau / limits) == pytest.approx(1.0) or F == pytest.approx(params.arm.tip_force_limit)


@pytest.mark.slow
def test_plan_keeps_contact_obeys_friction_and_slows_the_hull(contact_case, params, scene) -> None:
    """From Algorithm 2's guess the Mode III solve converges; the plan keeps the tip on the wall at
    every node (1e-5 m, IPOPT's acceptable constraint level), F_n >= 0, |F_t| <= mu F_n (1e-6 N),
    and F_t opposes the tip's sliding velocity, measured independently by finite differences of the
    planned tip positions (only where it slides faster than 1 mm/s). Physics: after 1 s the hull
    approaches the wall slower than the same model coasting with the arm held (no contact) - by at
    least 0.1 m/s."""
    model, ocp, h = contact_case
    s = ocp.settings
    guess = ocp.contact_guess(h, np.zeros((s.horizon, model.n_inputs)), None)
    sol = ocp.solve(h, guess)
    assert sol.status is SolverStatus.SUCCESS
    wall = scene.planes[0]
    assert max(abs(float(tip_gap(model, x, wall))) for x in sol.h[1:]) < 1e-5
    Fn, Ft = sol.force[:, 0], sol.force[:, 1:]
    assert np.all(Fn >= -1e-8)
    assert np.all(np.linalg.norm(Ft, axis=1) <= s.friction * Fn + 1e-6)
    tips = np.array([np.asarray(model.ee_pose(x)[0]).ravel() for x in sol.h])
    v_t = (np.diff(tips, axis=0) / s.dt) @ ocp.Rw[:, 1:]
    sliding = np.linalg.norm(v_t, axis=1) > 1e-3
    assert np.all(np.einsum("ij,ij->i", Ft[sliding], v_t[sliding]) <= 1e-9)
    coast = h.copy()
    for _ in range(100):
        coast = model.step(coast, np.zeros(model.n_inputs), s.dt * s.horizon / 100)
    d_dot = [float(np.asarray(model.closing_speeds(x, wall.normal, wall.offset)).ravel()[0])
             for x in (sol.h[-1], coast)]
    assert d_dot[0] > d_dot[1] + 0.1


@pytest.mark.slow
def test_spin_term_stops_the_hull_with_less_turn(contact_case, params, scene) -> None:
    """J_III's spin term (not in the paper), the contact case (every thruster dead) with and without
    it (weight 0.1 and 0 s^2/rad^2; with a live thruster the term is off): both plans stop the
    approach (the hull ends moving away from the wall). With the term the hull's peak angular rate
    is at least 10 % lower (21 % measured here; the margin is half of it) and so is its pitch
    excursion, and the contact force's moment about the hull's origin, computed here from the
    planned tip positions and forces (the plan has no moment in it), is smaller on average: the
    push that turns the hull is what the term trades. The strut term is off in both plans, so that
    the spin term acts alone."""
    model, ocp, h = contact_case
    assert ocp.settings.spin_weight == 0.1 and ocp.spin_weight() == 0.1
    lo, hi = params.input_bounds()
    live = ModeIIIOCP(model, scene.planes, 0, ModeIIISettings())
    live.limit_inputs(lo, hi)
    assert live.spin_weight() == 0.0
    lo[:8] = hi[:8] = 0.0
    with_spin = ModeIIIOCP(model, scene.planes, 0, ModeIIISettings(strut_weight=0.0))
    spinning = ModeIIIOCP(model, scene.planes, 0, ModeIIISettings(spin_weight=0.0, strut_weight=0.0))
    for o in (with_spin, spinning):
        o.limit_inputs(lo, hi)
    wall, nv = scene.planes[0], model.n_speeds
    peak, excursion, moment = [], [], []
    for o in (with_spin, spinning):
        sol = o.solve(h, o.contact_guess(h, np.zeros((o.settings.horizon, model.n_inputs)), None))
        assert sol.status is SolverStatus.SUCCESS
        assert float(np.asarray(model.closing_speeds(sol.h[-1], wall.normal, wall.offset)).ravel()[0]) > 0.0
        peak.append(np.abs(sol.h[:, nv + 3:nv + 6]).max())
        excursion.append(np.ptp(sol.h[:, 4]))
        tips = np.array([np.asarray(model.ee_pose(x)[0]).ravel() for x in sol.h])
        arm = (tips[:-1] + tips[1:] - sol.h[:-1, :3] - sol.h[1:, :3]) / 2  # interval midpoints
        moment.append(np.linalg.norm(np.cross(arm, sol.force @ o.Rw.T), axis=1).mean())
    assert peak[0] <= 0.9 * peak[1]
    assert excursion[0] < excursion[1]
    assert moment[0] < moment[1]


@pytest.mark.slow
def test_clearance_term_pushes_a_hull_that_is_too_close_back_out(params, scene) -> None:
    """J_III's clearance term (not in the paper): thrusters dead, the hull at rest 0.15 m from the
    wall with the tip on it, a 0.25 m/s current onto the wall. Asked for 0.18 m, the 1 s plan ends
    with the hull at least that far out, within half the relu's smoothing (its bias); J_III without
    the term (weight 0; the same compiled code, the two are parameters) lets the hull end short of
    it: the term is what pushes. The spin term, which trades part of that push for less turn, is
    off (weight 0) so that the clearance term acts alone."""
    model = UVMSModel(params, scene.water)
    wall, current, n = scene.planes[0], np.array([0.25, 0.0, 0.0]), params.n_joints
    lo, hi = params.input_bounds()
    lo[:params.n_thrusters] = hi[:params.n_thrusters] = 0.0
    h, _ = initial_state(params, wall_approach(0.15, 0.0))
    ocps = [ModeIIIOCP(model, scene.planes, 0, ModeIIISettings(hull_clearance=0.18, clearance_weight=w,
                                                               spin_weight=0.0)) for w in (1.0, 0.0)]
    h[6:6 + n] = ReachPosture(model, wall)(h)
    h[6:6 + n] = ocps[0].onto_plane(h)
    ends = []
    for ocp in ocps:
        ocp.limit_inputs(lo, hi)
        guess = ocp.contact_guess(h, np.zeros((ocp.settings.horizon, model.n_inputs)), None, current)
        sol = ocp.solve(h, guess, current)
        assert sol.status is SolverStatus.SUCCESS
        ends.append(float(np.asarray(model.distances(sol.h[-1], wall.normal, wall.offset)).ravel()[0]))
    s = ModeIIISettings()
    assert ends[0] >= 0.18 - s.clearance_smoothing / 2
    assert ends[1] < 0.18


def test_away_thrust_is_the_best_vertex_of_the_thrust_box(params, scene) -> None:
    """The thrust the hull can put along the wall's normal, away from it: a linear program over the
    box of thruster forces, whose optimum is a vertex; enumerated over all 2^8 vertices in a yawed,
    pitched attitude it agrees to 1e-9 N (rounding). Every thruster known dead: 0 N."""
    import itertools

    model = UVMSModel(params, scene.water)
    ocp = ModeIIIOCP(model, scene.planes, 0, ModeIIISettings())
    h, _ = initial_state(params, wall_approach(0.35, 0.3))
    h[3:6] = [0.1, -0.3, 0.7]
    lo, hi = params.input_bounds()
    nt = params.n_thrusters
    R = np.asarray(euler_zyx_np(h[3:6]))
    away = R @ params.allocation_matrix()[:3]
    box = itertools.product(*zip(lo[:nt], hi[:nt], strict=True))
    best = max(scene.planes[0].normal @ away @ np.array(f) for f in box)
    assert ocp.away_thrust(h) == pytest.approx(best, abs=1e-9)
    lo[:nt] = hi[:nt] = 0.0
    ocp.limit_inputs(lo, hi)
    assert ocp.away_thrust(h) == 0.0


def euler_zyx_np(rpy: np.ndarray) -> np.ndarray:
    """R = Rz Ry Rx (body to world) from elementary rotations, independent of controller.kinematics."""
    (cf, sf), (ct, st), (cp, sp) = ((np.cos(a), np.sin(a)) for a in rpy)
    Rx = np.array([[1, 0, 0], [0, cf, -sf], [0, sf, cf]])
    Ry = np.array([[ct, 0, st], [0, 1, 0], [-st, 0, ct]])
    Rz = np.array([[cp, -sp, 0], [sp, cp, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


@pytest.mark.slow
def test_first_interval_is_force_free_while_the_tip_is_off_the_wall_and_thrusters_live(contact_case, params,
                                                                                         scene) -> None:
    """`force_free_gap`: from the contact case with the hull 2 cm further out (tip 2 cm off the wall),
    the first interval's planned normal force is 0 (its bound; 1e-8 N, IPOPT's bound push) when the
    thrusters live; with every thruster dead the arm is the hull's only brake and the same solve
    plans a push from the first interval on (above 1 N)."""
    model, dead, h = contact_case
    h = h.copy()
    h[0] -= 0.02
    assert float(tip_gap(model, h, scene.planes[0])) > 0.015
    live = ModeIIIOCP(model, scene.planes, 0, ModeIIISettings())
    first = []
    for ocp in (live, dead):
        guess = ocp.contact_guess(h, np.zeros((ocp.settings.horizon, model.n_inputs)), None)
        sol = ocp.solve(h, guess)
        assert sol.status.usable
        first.append(sol.force[0, 0])
    assert abs(first[0]) < 1e-8
    assert first[1] > 1.0


def test_projection_onto_the_wall_matches_ipopt(contact_case, scene) -> None:
    """`onto_plane`'s SQP iteration against IPOPT on the same 4-variable problem, from 200 states
    scattered around the contact case (hull +-5 cm and +-0.2 rad, joints +-0.3 rad): the tip on the
    plane (1e-9 m), the joints within range, and the posture at most 1e-8 rad (rounding of two
    solvers stopped at 1e-10) further from h's than IPOPT's, never a worse local solution."""
    model, ocp, h = contact_case
    n, wall = model.n_joints, scene.planes[0]
    rng = np.random.default_rng(0)
    for _ in range(200):
        x = h.copy()
        x[:3] += rng.uniform(-0.05, 0.05, 3)
        x[3:6] += rng.uniform(-0.2, 0.2, 3)
        x[6:6 + n] += rng.uniform(-0.3, 0.3, n)
        q, q_ipopt = ocp.onto_plane(x), ocp.onto_plane_ipopt(x)
        y = x.copy()
        y[6:6 + n] = q
        assert abs(float(tip_gap(model, y, wall))) < 1e-9
        assert np.all((q >= ocp._q_lo) & (q <= ocp._q_hi))
        assert np.linalg.norm(q - x[6:6 + n]) <= np.linalg.norm(q_ipopt - x[6:6 + n]) + 1e-8


def test_regular_angles_solve_a_hull_pitched_89_deg_in_the_worlds_terms(params, scene) -> None:
    """A Mode III problem recorded in a thrusters-dead closed loop with the hull pitched 88.9 deg
    (tests/data), solved with `regular_pitch` = 75 deg, i.e. in angles relative to a 90 deg-pitched
    frame: the plan comes back in the world's angles, judged by the world's model (an independent
    reading of every node's attitude): it starts at the measured state (1e-9), keeps the tip on the
    wall (the problem's constraint tolerance, 1e-5 m) and every other body at least the margin off
    (less 1e-5 m)."""
    d = np.load(Path(__file__).parent / "data" / "thrusters_dead_mode3_pitched.npz")
    model = UVMSModel(params, scene.water)
    contact = int(d["contact"])
    ocp = ModeIIIOCP(model, scene.planes, contact, ModeIIISettings(regular_pitch=75.0))
    ocp.limit_inputs(d["lo"], d["hi"])
    sol = ocp.solve(d["h0"], d["guess"], d["current"], (d["lam_g"], d["lam_x"]))
    assert sol.status.usable
    np.testing.assert_allclose(sol.h[0], d["h0"], atol=1e-9)
    plane = scene.planes[contact]
    assert max(abs(float(tip_gap(model, x, plane))) for x in sol.h[1:]) <= 1e-5
    assert min(float(np.min(np.asarray(ocp._clearance(x)))) for x in sol.h[1:]) >= ocp.settings.distance_margin - 1e-5


def test_strut_weight_shortens_the_moment_arm_it_prices(params, scene) -> None:
    """The recorded thrusters-dead Mode III problem above (every thruster dead, the hull pitched
    88.9 deg): with `strut_weight` = 1 m^-2 the plan's squared moment arms (controller.mode3.strut_arm,
    checked against MuJoCo in tests/test_model_vs_mujoco.py) summed over its nodes are smaller than
    without the term, and the plan stays usable with the tip on the wall (1e-5 m). Oracle: the same
    problem solved with the weight 0, from the same start."""
    import casadi as ca

    from controller.mode3 import strut_arm

    d = np.load(Path(__file__).parent / "data" / "thrusters_dead_mode3_pitched.npz")
    model = UVMSModel(params, scene.water)
    contact = int(d["contact"])
    plane = scene.planes[contact]
    h = ca.SX.sym("h", params.n_states)
    arm2 = ca.Function("arm2", [h], [ca.sumsqr(strut_arm(model, h, plane))])
    total = {}
    for weight in (0.0, 1.0):
        ocp = ModeIIIOCP(model, scene.planes, contact, ModeIIISettings(strut_weight=weight))
        ocp.limit_inputs(d["lo"], d["hi"])
        sol = ocp.solve(d["h0"], d["guess"], d["current"], (d["lam_g"], d["lam_x"]))
        assert sol.status.usable
        assert max(abs(float(tip_gap(model, x, plane))) for x in sol.h[1:]) <= 1e-5
        total[weight] = sum(float(arm2(x)) for x in sol.h[1:])
    assert total[1.0] < total[0.0]
