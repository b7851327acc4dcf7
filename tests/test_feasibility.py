"""Mode I's feasibility certificate on head-on approaches to the wall with the arm stowed."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from controller.feasibility import Certificate, FeasibilityTest, Method, Stop, Verdict
from controller.mode1 import PITCH, ModeISettings
from controller.model import UVMSModel
from controller.rollouts import simulate
from controller.transcription import FEASIBLE_VIOLATION, SolverStatus
from validation.closed_loop import SHARP

WALL_X = 2.0  # m, the default scene's wall
AS_MEASURED = ModeISettings(pitch_limit=None)  # Mode I before its pitch bound (the opt-in screens' tests)


@pytest.fixture(scope="module")
def certificate(params, scene) -> FeasibilityTest:
    return FeasibilityTest(UVMSModel(params, scene.water), scene.planes)


@pytest.fixture(scope="module")
def searching(certificate, scene) -> FeasibilityTest:
    """The certificate with its optional line-search SQP screen (20 iterations)."""
    return FeasibilityTest(certificate.model, scene.planes, search_iterations=20)


@pytest.fixture(scope="module")
def sharp(params, scene) -> FeasibilityTest:
    """The certificate as it was until 2026-12-01, where the opt-in screens below were measured and
    are run: on the sharp model (validation.closed_loop.SHARP: the superellipsoids smoothed at 1e-7
    m), without the pitch bound and with IPOPT run to its end (no stop)."""
    return FeasibilityTest(UVMSModel(params, scene.water, SHARP), scene.planes, AS_MEASURED, stop=Stop.NONE,
                           plan_start=False)


@pytest.fixture(scope="module")
def sharp_searching(sharp, scene) -> FeasibilityTest:
    return FeasibilityTest(sharp.model, scene.planes, AS_MEASURED, search_iterations=20, stop=Stop.NONE,
                           plan_start=False)


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


@pytest.mark.slow
@pytest.mark.parametrize(("gap", "speed", "verdict", "method"), [
    (1.5, 0.3, Verdict.FEASIBLE, Method.BRAKING_ROLLOUT),
    (0.2, 0.5, Verdict.FEASIBLE, Method.BRAKING_ROLLOUT),
    (0.07, 0.3, Verdict.FEASIBLE, Method.MINIMUM_VIOLATION),
    (0.05, 0.8, Verdict.INFEASIBLE, Method.MINIMUM_VIOLATION),
], ids=["far", "braking suffices", "tight: the rollout fails, the OCP does not", "unavoidable"])
def test_certificate(certificate, params, gap, speed, verdict, method) -> None:
    """The braking rollout certifies easy cases by exhibiting a feasible point; a tight case it
    cannot certify is certified by a zero minimum violation (below the 1 mm tolerance); the
    unavoidable case (0.8 m/s, 5 cm: maximum braking needs about 7 cm) leaves a clearly positive
    minimum violation (more than 10 times the tolerance; IPOPT's local optima here were 2.5 and
    12.8 cm from two starting points: the problem is not convex)."""
    h, ref = approach(params, gap, speed)
    c = certificate(h, ref)
    assert (c.verdict, c.method) == (verdict, method)
    if method is Method.MINIMUM_VIOLATION:
        assert c.rollout_clearance < 0
        if verdict is Verdict.FEASIBLE:
            assert c.violation <= certificate.tolerance
        else:
            assert c.violation > 10 * certificate.tolerance


@pytest.mark.slow
def test_screens_alone_leave_the_tight_case_undecided(certificate, params) -> None:
    """minimum_violation=False (SwitchingSettings.minimum_violation, "switching-screens"): a case the
    braking rollout certifies gets the full test's verdict; the tight case, which only the
    minimum-violation problem certifies (zero violation), is UNDECIDED (no violation: nan, no
    solution: the problem was not solved)."""
    h, ref = approach(params, 0.2, 0.5)
    assert certificate(h, ref, minimum_violation=False).method is Method.BRAKING_ROLLOUT
    h, ref = approach(params, 0.07, 0.3)
    screened, full = certificate(h, ref, minimum_violation=False), certificate(h, ref)
    assert (screened.verdict, screened.method) == (Verdict.UNDECIDED, Method.SCREENS) and np.isnan(screened.violation)
    assert (full.verdict, full.method) == (Verdict.FEASIBLE, Method.MINIMUM_VIOLATION)
    assert screened.solution is None and full.solution is not None


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
def test_two_algorithms_agree_on_the_tight_case(searching, params) -> None:
    """Independent evidence for the tight case above, which the default certificate certifies by a
    zero minimum violation (IPOPT on the slack formulation): the line-search SQP screen certifies
    it too, and its plan's inputs re-simulated by RK4 (20 substeps an interval, independent of the
    transcription) keep every body the 2 cm margin off every plane at every node, within the input
    and joint bounds."""
    h, ref = approach(params, 0.07, 0.3)
    c = searching(h, ref)
    assert (c.verdict, c.method) == (Verdict.FEASIBLE, Method.GLOBALIZED_SQP)
    assert searching.plan_is_feasible(simulate(searching.model, h, c.solution.u, searching.settings.dt, 20),
                                      c.solution.u)


@pytest.mark.slow
def test_search_screen_avoids_a_false_unavoidable(sharp, sharp_searching, params) -> None:
    """0.5 m/s with the hull's front 10 cm from the wall, on the sharp model (1e-7 m smoothing). The
    minimum-violation IPOPT fails on this problem (an infinite violation), so the default certificate
    takes the safe side and says 'unavoidable'; the line-search SQP's plan shows that F is not empty.
    (IPOPT passes an iterate with zero slack that satisfies the midpoint rule, but its inputs under
    RK4 roll the hull over, so the certificate's stop rightly does not take it.)
    Oracle: its inputs re-simulated by RK4 (20 substeps an interval) keep every body the 2 cm margin
    off every plane at every node, within the input and joint bounds."""
    h, ref = approach(params, 0.1, 0.5)
    c = sharp_searching(h, ref)
    assert (c.verdict, c.method) == (Verdict.FEASIBLE, Method.GLOBALIZED_SQP)
    hs = simulate(sharp_searching.model, h, c.solution.u, sharp_searching.settings.dt, substeps=20)
    assert sharp_searching.plan_is_feasible(hs, c.solution.u)
    alone = sharp(h, ref)
    assert alone.verdict is Verdict.INFEASIBLE and alone.violation == np.inf


@pytest.mark.slow
def test_default_smoothing_removes_the_false_unavoidables(certificate, scene, params) -> None:
    """The two calls where, on the sharp model, the default certificate's IPOPT fails and so says
    'unavoidable' although F is not empty (the tests around this one): with the default smoothing
    (1e-3 m) its minimum-violation problem converges to a zero minimum in both. Oracle: the plan's
    inputs re-simulated by RK4 (20 substeps an interval; the recorded current and thruster bounds for
    the MuJoCo call) keep every body the 2 cm margin off every plane at every node, within bounds
    (measured 3.0 and 4.9 cm)."""
    h, ref = approach(params, 0.1, 0.5)
    rec = np.load(Path(__file__).parent / "data" / "wall_headon_certificate_call.npz")
    calls = [(h, ref, None, None, None), (rec["h0"], rec["h_ref"], rec["current"], rec["input_lo"], rec["input_hi"])]
    try:
        for h0, h_ref, current, lo, hi in calls:
            if lo is not None:
                certificate.limit_inputs(lo, hi)
            fresh = (rec["fresh_h"], rec["fresh_u"]) if lo is not None else None
            c = certificate(h0, h_ref, current, fresh=(lambda f=fresh: f) if fresh else None)
            assert (c.verdict, c.method) == (Verdict.FEASIBLE, Method.MINIMUM_VIOLATION)
            assert c.violation <= certificate.tolerance
            hs = simulate(certificate.model, h0, c.solution.u, certificate.settings.dt, substeps=20, current=current)
            assert certificate.plan_is_feasible(hs, c.solution.u)
    finally:
        certificate.limit_inputs(*params.input_bounds())


@pytest.mark.slow
def test_line_search_reaches_F_where_full_steps_do_not(sharp_searching) -> None:
    """On the sharp model (where the screen was measured): a step of the Kane-model closed loop with
    every thruster dead (the Kane-model closed loop's kane-thrusters-dead approach, t = 0.7 s; recorded
    in tests/data): only the arm's reaction can slow
    the hull. From the previous plan shifted, Mode I's SQP with full steps ends 20 iterations with
    its constraints violated by more than 1e-2 (m, N or N m); with the l1-merit line search it
    reaches a point of F (violation below FEASIBLE_VIOLATION). Oracle: that plan's inputs
    re-simulated by RK4 (20 substeps an interval) keep every body within 0.5 mm of the 2 cm margin
    (the implicit midpoint rule at dt = 0.1 s and RK4 differ by that much here; measured 0.1 mm)."""
    rec = np.load(Path(__file__).parent / "data" / "thrusters_dead_drift_step.npz")
    test = sharp_searching
    try:
        test.limit_inputs(rec["input_lo"], rec["input_hi"])
        guess = test.search.guess_from_rollout(rec["plan_h"], rec["plan_u"])
        full = test.search.solve(rec["h0"], rec["h_ref"], guess=guess,
                                 sqp=replace(test.search_settings, line_search=False))
        searched = test.search.solve(rec["h0"], rec["h_ref"], guess=guess, sqp=test.search_settings)
    finally:
        test.limit_inputs(*test.model.params.input_bounds())
    assert full.violation > 1e-2
    assert searched.violation <= FEASIBLE_VIOLATION
    hs = simulate(test.model, rec["h0"], searched.u, test.settings.dt, substeps=20)
    assert test.min_clearance(hs) >= test.settings.distance_margin - 5e-4


@pytest.mark.slow
def test_warm_start_finds_F_where_the_default_start_fails(sharp, scene) -> None:
    """On the sharp model (where the warm start was measured): a certificate call of a MuJoCo closed
    loop (wall-headon, mismatch seed 1, t = 1.9 s; recorded in tests/data with Mode I's fresh plan):
    the screens fail, and the minimum-violation problem from the braking rollout ends in an IPOPT
    failure, so the default certificate says F is empty
    (infinite violation) and the controller switched to Mode II there. Started from the fresh plan
    (`warm_start`), it finds a zero minimum violation. Oracle: that plan's inputs re-simulated by
    RK4 (20 substeps an interval, the recorded current) stay within bounds and keep every body at
    least the 2 cm margin off (measured 4.9 cm)."""
    rec = np.load(Path(__file__).parent / "data" / "wall_headon_certificate_call.npz")
    warm = FeasibilityTest(sharp.model, scene.planes, AS_MEASURED, warm_start=True, stop=Stop.NONE)
    fresh = (rec["fresh_h"], rec["fresh_u"])
    verdicts = []
    for test in (sharp, warm):
        try:
            test.limit_inputs(rec["input_lo"], rec["input_hi"])
            verdicts.append(test(rec["h0"], rec["h_ref"], rec["current"], fresh=lambda: fresh))
            if test is warm:
                hs = simulate(test.model, rec["h0"], verdicts[-1].solution.u, test.settings.dt, substeps=20,
                              current=rec["current"])
                within = test.problem.plan_within_bounds(hs, verdicts[-1].solution.u)
        finally:
            test.limit_inputs(*test.model.params.input_bounds())
    default, started = verdicts
    assert default.verdict is Verdict.INFEASIBLE and default.violation == np.inf
    assert started.verdict is Verdict.FEASIBLE and started.method is Method.MINIMUM_VIOLATION
    assert within and warm.min_clearance(hs) >= warm.settings.distance_margin


@pytest.mark.slow
def test_retry_from_the_fresh_plan_finds_F_where_the_first_start_fails(sharp, scene) -> None:
    """`retry` (opt-in, `--controller switching-retry`) on the recorded MuJoCo call above, on the sharp
    model, where IPOPT fails on the minimum-violation problem from the braking rollout: solved again
    with the same options from Mode I's fresh plan, it reaches a zero minimum violation. Oracle: the
    plan's inputs re-simulated by RK4 (20 substeps an interval, the recorded current) stay within
    bounds and keep every body at least the 2 cm margin off (measured 4.9 cm)."""
    rec = np.load(Path(__file__).parent / "data" / "wall_headon_certificate_call.npz")
    retrying = FeasibilityTest(sharp.model, scene.planes, AS_MEASURED, retry=True, stop=Stop.NONE, plan_start=False)
    retrying.limit_inputs(rec["input_lo"], rec["input_hi"])
    c = retrying(rec["h0"], rec["h_ref"], rec["current"], fresh=lambda: (rec["fresh_h"], rec["fresh_u"]))
    assert (c.verdict, c.method) == (Verdict.FEASIBLE, Method.MINIMUM_VIOLATION)
    hs = simulate(retrying.model, rec["h0"], c.solution.u, retrying.settings.dt, substeps=20, current=rec["current"])
    assert retrying.plan_is_feasible(hs, c.solution.u)


@pytest.fixture(scope="module")
def oblique_call() -> tuple[UVMSModel, tuple, dict, Certificate]:
    """The controller's model and planes of wall-oblique (mismatch seed 1), a certificate call of its
    MuJoCo closed loop (the run's third minimum-violation problem; recorded in tests/data with the
    current and the dead horizontal thrusters' bounds), and the certificate as it was before the
    pitch bound and the stop (AS_MEASURED, IPOPT run to its end) on it."""
    from validation import mismatch, scenarios
    from validation.closed_loop import build_plant

    controller_params, scene, _, _ = build_plant(scenarios.get("wall-oblique"), mismatch.DEFAULT, 1)
    rec = dict(np.load(Path(__file__).parent / "data" / "wall_oblique_certificate_call.npz"))
    model = UVMSModel(controller_params, scene.water)
    return model, scene.planes, rec, certify(model, scene.planes, rec, AS_MEASURED, stop=Stop.NONE)[1]


def certify(model: UVMSModel, planes, rec: dict, settings: ModeISettings, stop: Stop) -> tuple[FeasibilityTest,
                                                                                                Certificate]:
    test = FeasibilityTest(model, planes, settings, stop=stop)
    test.limit_inputs(rec["input_lo"], rec["input_hi"])
    return test, test(rec["h0"], rec["h_ref"], rec["current"])


@pytest.mark.slow
def test_stop_at_the_first_point_of_F_removes_a_false_unavoidable(oblique_call) -> None:
    """Without Mode I's pitch bound (which alone also removes this false 'unavoidable', next test),
    on the recorded wall-oblique call (oblique_call): run to its end, IPOPT reaches a point of F on
    the way but walks away from it and ends at its 300-iteration cap with slacks of metres, so the
    certificate says 'unavoidable'; with the stop (the default) the solve ends at that point.
    Oracle: the plan's inputs re-simulated by RK4 (20 substeps an interval, not the 4 of the stop's
    own check) stay within bounds and keep every body at least the 2 cm margin off (measured 5.6 cm)."""
    model, planes, rec, walked = oblique_call
    test, stopped = certify(model, planes, rec, AS_MEASURED, stop=Stop.SLACK)
    assert walked.verdict is Verdict.INFEASIBLE and walked.violation == np.inf
    assert walked.solution.iterations == test.problem.settings.max_iter
    assert (stopped.verdict, stopped.method) == (Verdict.FEASIBLE, Method.MINIMUM_VIOLATION)
    assert stopped.solution.iterations < walked.solution.iterations
    hs = simulate(model, rec["h0"], stopped.solution.u, test.settings.dt, substeps=20, current=rec["current"])
    assert test.plan_is_feasible(hs, stopped.solution.u)


@pytest.mark.slow
def test_pitch_bound_keeps_the_certificate_off_the_euler_singularity(oblique_call) -> None:
    """The same call, IPOPT run to its end both times: without a pitch bound its iterates pitch the
    hull past 90 deg, where the ZYX Euler rates are singular, and it ends at its cap ('unavoidable');
    with Mode I's default bound (|pitch| <= 1.2 rad at every node) it converges to a zero minimum
    violation. Oracle: that plan's inputs re-simulated by RK4 (20 substeps an interval) keep every
    body the 2 cm margin off, within the input, joint and pitch bounds."""
    model, planes, rec, unbounded = oblique_call
    test, bounded = certify(model, planes, rec, ModeISettings(), stop=Stop.NONE)
    assert unbounded.verdict is Verdict.INFEASIBLE and np.abs(unbounded.solution.h[:, PITCH]).max() > np.pi / 2
    assert (bounded.verdict, bounded.method) == (Verdict.FEASIBLE, Method.MINIMUM_VIOLATION)
    assert bounded.solution.status is SolverStatus.SUCCESS
    hs = simulate(model, rec["h0"], bounded.solution.u, test.settings.dt, substeps=20, current=rec["current"])
    assert test.plan_is_feasible(hs, bounded.solution.u)
    assert np.abs(hs[:, PITCH]).max() <= test.settings.pitch_limit


@pytest.mark.slow
def test_witness_from_mode_one_plan_proves_F_in_a_few_iterations(params) -> None:
    """The default minimum-violation start and stop (Mode I's fresh plan; Stop.WITNESS) on a certificate
    call of a MuJoCo closed loop (wall-oblique, mismatch seed 1; recorded in tests/data with the fresh
    plan, which, re-simulated, puts a body 24 cm through the wall, so every screen fails): IPOPT stops
    at its third iterate, whose inputs re-simulated are a point of F, where the fifth session's
    certificate (from the braking rollout, stopped only once its slacks sum to 1 mm: Stop.SLACK) needs
    137 iterations for the same verdict. Oracle: the witness's inputs re-simulated by RK4 at 20
    substeps an interval (the stop's own check uses 4) stay within bounds and keep every body at least
    the 2 cm margin off (measured 5.5 cm)."""
    from validation import mismatch, scenarios
    from validation.closed_loop import build_plant

    controller_params, scene, _, _ = build_plant(scenarios.get("wall-oblique"), mismatch.DEFAULT, 1)
    model = UVMSModel(controller_params, scene.water)
    rec = dict(np.load(Path(__file__).parent / "data" / "wall_oblique_fresh_plan_call.npz"))
    out = {}
    for stop, plan_start in ((Stop.WITNESS, True), (Stop.SLACK, False)):
        test = FeasibilityTest(model, scene.planes, stop=stop, plan_start=plan_start)
        test.limit_inputs(rec["input_lo"], rec["input_hi"])
        out[stop] = test(rec["h0"], rec["h_ref"], rec["current"], fresh=lambda: (rec["fresh_h"], rec["fresh_u"]))
    assert not test.plan_is_feasible(rec["fresh_h"], rec["fresh_u"])
    witness, slack = out[Stop.WITNESS], out[Stop.SLACK]
    assert (witness.verdict, witness.method) == (slack.verdict, slack.method) == (Verdict.FEASIBLE,
                                                                                   Method.MINIMUM_VIOLATION)
    assert witness.solution.status is SolverStatus.STOPPED and witness.violation == 0.0
    assert 5 * witness.solution.iterations < slack.solution.iterations
    hs = simulate(model, rec["h0"], witness.solution.u, test.settings.dt, substeps=20, current=rec["current"])
    assert test.plan_is_feasible(hs, witness.solution.u)
