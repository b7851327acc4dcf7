"""Mode I's feasibility certificate on head-on approaches to the wall with the arm stowed, and on
certificate calls recorded in MuJoCo closed loops.

Every FEASIBLE verdict here is checked against an independent oracle: the plan's inputs
re-simulated by RK4 at 20 substeps an interval (the controller's own checks use 4) keep every body
the margin off every plane at every node, within the input and joint bounds. No test asks that a
solver fails: whether a nonconvex solve from a given start fails hangs on the last bits of the
linear algebra, which differ between CPUs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from controller.feasibility import Certificate, CertificateSettings, FeasibilityTest, Method, Verdict
from controller.mode1 import PITCH, ModeIOCP, ModeISettings
from controller.model import UVMSModel
from controller.rollouts import simulate
from controller.transcription import SolverStatus

WALL_X = 2.0  # m, the default scene's wall
DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def certificate(params, scene) -> FeasibilityTest:
    return FeasibilityTest(UVMSModel(params, scene.water), scene.planes)


def approach(params, gap: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """Hull front `gap` [m] from the wall (hull superellipsoid semi-axis a ahead of its origin),
    moving at `speed` [m/s] towards it, arm stowed; the task target 1 m from the wall."""
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[0] = WALL_X - params.hull.superellipsoid.semi_axes[0] - gap
    h[6:6 + n], h[6 + n] = params.arm.stowed, speed
    ref = h.copy()
    ref[0], ref[6 + n] = WALL_X - 1.0, 0.0
    return h, ref


def assert_certified(test: FeasibilityTest, h0: np.ndarray, c: Certificate, current: np.ndarray | None = None) -> None:
    """The oracle: a FEASIBLE minimum-violation verdict whose plan, re-simulated by RK4 at 20
    substeps an interval from h0, is a point of F (plan_is_feasible: clearances above the margin at
    every node, inputs and joint angles within bounds). A witness (STOPPED) has violation 0 by
    construction; a converged solve has its slack sum within the tolerance."""
    assert (c.verdict, c.method) == (Verdict.FEASIBLE, Method.MINIMUM_VIOLATION)
    assert c.solution.status in (SolverStatus.STOPPED, SolverStatus.SUCCESS, SolverStatus.FEASIBLE)
    assert c.violation <= test.tolerance
    hs = simulate(test.model, h0, c.solution.u, test.settings.dt, substeps=20, current=current)
    assert test.plan_is_feasible(hs, c.solution.u)


def recorded(name: str) -> dict:
    return dict(np.load(DATA / name))


def certify_call(test: FeasibilityTest, rec: dict, fresh: bool = False) -> Certificate:
    """The certificate of a recorded call, under the call's input bounds (restored after), with the
    call's fresh Mode I plan as the third screen when `fresh`."""
    plan = (rec["fresh_h"], rec["fresh_u"]) if fresh else None
    try:
        test.limit_inputs(rec["input_lo"], rec["input_hi"])
        return test(rec["h0"], rec["h_ref"], rec["current"], fresh=(lambda: plan) if fresh else None)
    finally:
        test.limit_inputs(*test.model.params.input_bounds())


@pytest.mark.slow
@pytest.mark.parametrize(("gap", "speed", "verdict", "method"), [
    (1.5, 0.3, Verdict.FEASIBLE, Method.BRAKING_ROLLOUT),
    (0.2, 0.5, Verdict.FEASIBLE, Method.BRAKING_ROLLOUT),
    (0.07, 0.3, Verdict.FEASIBLE, Method.MINIMUM_VIOLATION),
    (0.05, 0.8, Verdict.INFEASIBLE, Method.MINIMUM_VIOLATION),
], ids=["far", "braking suffices", "tight: the rollout fails, the OCP does not", "unavoidable"])
def test_certificate(certificate, params, gap, speed, verdict, method) -> None:
    """The braking rollout certifies easy cases by exhibiting a feasible point (its own clearance is
    the oracle: a closed rollout, no solver); a tight case it cannot certify is certified by the
    minimum-violation problem (oracle: assert_certified); the unavoidable case (0.8 m/s, 5 cm:
    maximum braking needs about 7 cm) cannot be certified, since no point of F exists: its minimum
    violation is more than 10 times the tolerance (IPOPT's local optima here were 2.5 and 12.8 cm),
    or infinite where IPOPT fails (counted as F empty, the safe side)."""
    h, ref = approach(params, gap, speed)
    c = certificate(h, ref)
    assert (c.verdict, c.method) == (verdict, method)
    if method is Method.BRAKING_ROLLOUT:
        assert c.rollout_clearance >= 0
    elif verdict is Verdict.FEASIBLE:
        assert c.rollout_clearance < 0
        assert_certified(certificate, h, c)
    else:
        assert c.rollout_clearance < 0 and c.violation > 10 * certificate.tolerance


@pytest.mark.slow
def test_a_question_not_needed_is_left_undecided(certificate, params) -> None:
    """`needed` returning False (the deploy deadline decides either way): a case the braking rollout
    certifies gets the full verdict; the tight case, which only the minimum-violation problem
    certifies, is UNDECIDED without a solve (no violation: nan, no solution), and the full test on
    it is certified (oracle: assert_certified)."""
    never = lambda c: False  # noqa: E731
    h, ref = approach(params, 0.2, 0.5)
    assert certificate(h, ref, needed=never).method is Method.BRAKING_ROLLOUT
    h, ref = approach(params, 0.07, 0.3)
    screened, full = certificate(h, ref, needed=never), certificate(h, ref)
    assert (screened.verdict, screened.method) == (Verdict.UNDECIDED, Method.SCREENS) and np.isnan(screened.violation)
    assert screened.solution is None
    assert_certified(certificate, h, full)


@pytest.mark.slow
def test_plan_screen_accepts_only_plans_inside_the_bounds(certificate, params) -> None:
    """The plan screens (previous plan, fresh Mode I plan) certify F by exhibiting a point of it.
    Oracle: the braking rollout of the 'far' case, which keeps every clearance above the margin
    (the certificate's own first screen says so), is accepted; the same states with one thruster
    input 1 N beyond its bound, or with the hull's front at the last node 1 cm from the wall (inside
    the 2 cm margin), are not."""
    h, ref = approach(params, 1.5, 0.3)
    assert certificate(h, ref).method is Method.BRAKING_ROLLOUT
    hs, us = certificate.braking_rollout(h)
    assert certificate.plan_is_feasible(hs, us)
    hi = params.input_bounds()[1]
    over = us.copy()
    over[3, 0] = hi[0] + 1.0
    assert not certificate.plan_is_feasible(hs, over)
    close = hs.copy()
    close[-1, 0] += WALL_X - 0.01 - (hs[-1, 0] + params.hull.superellipsoid.semi_axes[0])  # hull front 1 cm off
    assert not certificate.plan_is_feasible(close, us)


@pytest.mark.slow
def test_default_certificate_on_recorded_calls(certificate, params) -> None:
    """Two calls where the certificate once said 'unavoidable' although F is not empty: a head-on
    approach at 0.5 m/s with the hull's front 10 cm from the wall, and a MuJoCo closed loop's call
    (wall-headon, mismatch seed 1, t = 1.9 s; recorded with its current, thruster bounds and Mode I's
    fresh plan). The default certificate certifies both (oracle: assert_certified, with the recorded
    current)."""
    h, ref = approach(params, 0.1, 0.5)
    rec = recorded("wall_headon_certificate_call.npz")
    calls = [(h, ref, None, None, None), (rec["h0"], rec["h_ref"], rec["current"], rec["input_lo"], rec["input_hi"])]
    try:
        for h0, h_ref, current, lo, hi in calls:
            if lo is not None:
                certificate.limit_inputs(lo, hi)
            fresh = (rec["fresh_h"], rec["fresh_u"]) if lo is not None else None
            c = certificate(h0, h_ref, current, fresh=(lambda f=fresh: f) if fresh else None)
            assert_certified(certificate, h0, c, current)
    finally:
        certificate.limit_inputs(*params.input_bounds())


@pytest.fixture(scope="module")
def oblique() -> tuple[FeasibilityTest, dict]:
    """The certificate of wall-oblique's controller (its model and planes, mismatch seed 1) with the
    recorded call's dead horizontal thrusters; and a certificate call of its MuJoCo closed loop (the
    run's third minimum-violation problem, recorded with the current and the thruster bounds)."""
    from validation import mismatch, scenarios
    from validation.closed_loop import build_plant

    controller_params, scene, _, _ = build_plant(scenarios.get("wall-oblique"), mismatch.DEFAULT, 1)
    test = FeasibilityTest(UVMSModel(controller_params, scene.water), scene.planes)
    return test, recorded("wall_oblique_certificate_call.npz")


@pytest.mark.slow
def test_stopped_solve_returns_a_certified_point_of_F(oblique) -> None:
    """On the recorded wall-oblique call (where, before the witness stop and the pitch bound, IPOPT
    reached a point of F on the way and then walked away from it to its 300-iteration cap): the
    default certificate's solve ends at a certified point of F (oracle: assert_certified), and when
    it stopped early (STOPPED), the plan it carries is its inputs' own RK4 re-simulation from h0."""
    test, rec = oblique
    c = certify_call(test, rec)
    assert_certified(test, rec["h0"], c, rec["current"])
    if c.solution.status is SolverStatus.STOPPED:
        np.testing.assert_array_equal(c.solution.h, simulate(test.model, rec["h0"], c.solution.u, test.settings.dt,
                                                             current=rec["current"]))


@pytest.mark.slow
def test_pitch_bound_holds_on_the_certificate_plan(oblique) -> None:
    """Mode I's pitch bound (|pitch| <= 1.2 rad at every node, away from the ZYX Euler singularity at
    90 deg, where the certificate's IPOPT once wandered to its cap): on the same recorded call, the
    bounded problem's plan is a point of F (oracle: assert_certified) whose re-simulated pitch stays
    within the bound, by RK4 at 20 substeps, not by the solver's own account."""
    test, rec = oblique
    assert test.settings.pitch_limit == ModeISettings().pitch_limit == 1.2
    c = certify_call(test, rec)
    assert_certified(test, rec["h0"], c, rec["current"])
    hs = simulate(test.model, rec["h0"], c.solution.u, test.settings.dt, substeps=20, current=rec["current"])
    assert np.abs(hs[:, PITCH]).max() <= test.settings.pitch_limit


@pytest.mark.slow
def test_witness_from_mode_one_plan_certifies_where_every_screen_fails(params) -> None:
    """A certificate call of a MuJoCo closed loop (wall-oblique, mismatch seed 1; recorded in
    tests/data with Mode I's fresh plan, which, re-simulated, puts a body 24 cm through the wall, so
    every screen fails): the minimum-violation problem, started from that plan, is certified (oracle:
    assert_certified)."""
    from validation import mismatch, scenarios
    from validation.closed_loop import build_plant

    controller_params, scene, _, _ = build_plant(scenarios.get("wall-oblique"), mismatch.DEFAULT, 1)
    test = FeasibilityTest(UVMSModel(controller_params, scene.water), scene.planes)
    rec = recorded("wall_oblique_fresh_plan_call.npz")
    test.limit_inputs(rec["input_lo"], rec["input_hi"])
    assert not test.plan_is_feasible(rec["fresh_h"], rec["fresh_u"])
    c = certify_call(test, rec, fresh=True)
    assert_certified(test, rec["h0"], c, rec["current"])


@pytest.mark.slow
def test_continued_plan_certifies_where_every_screen_fails(params) -> None:
    """The same recorded wall-oblique call: Mode I's fresh plan, its states re-simulated (a
    consistent start that puts a body 24 cm through the wall; the closed loop continues the SQP's
    own iterate instead), continued by Mode I's SQP with the line search for up to 16 iterations,
    stops at an iterate whose inputs are a point of F (11 iterations on this machine), and the
    certificate given it says so (REFINED_PLAN) without the minimum-violation problem. Oracle: those
    inputs re-simulated by RK4 at 20 substeps an interval pass plan_is_feasible, and the plan
    carried is its inputs' own 4-substep re-simulation from h0."""
    from validation import mismatch, scenarios
    from validation.closed_loop import build_plant

    controller_params, scene, _, _ = build_plant(scenarios.get("wall-oblique"), mismatch.DEFAULT, 1)
    model = UVMSModel(controller_params, scene.water)
    test = FeasibilityTest(model, scene.planes, certificate=CertificateSettings(refine_iterations=16))
    ocp = ModeIOCP(model, scene.planes)
    rec = recorded("wall_oblique_fresh_plan_call.npz")
    test.limit_inputs(rec["input_lo"], rec["input_hi"])
    ocp.limit_inputs(rec["input_lo"], rec["input_hi"])
    h0, current = rec["h0"], rec["current"]
    assert not test.plan_is_feasible(rec["fresh_h"], rec["fresh_u"])
    found = test.continued(ocp, h0, rec["h_ref"], current, ocp.guess_from_rollout(rec["fresh_h"], rec["fresh_u"]))
    assert found is not None
    hs, sol = found
    assert sol.status is SolverStatus.STOPPED and sol.iterations <= 16
    np.testing.assert_array_equal(hs, simulate(model, h0, sol.u, test.settings.dt, current=current))
    assert test.plan_is_feasible(simulate(model, h0, sol.u, test.settings.dt, substeps=20, current=current), sol.u)
    c = test(h0, rec["h_ref"], current, fresh=lambda: (rec["fresh_h"], rec["fresh_u"]), refine=lambda _: (hs, sol.u))
    assert (c.verdict, c.method, c.solution) == (Verdict.FEASIBLE, Method.REFINED_PLAN, None)
