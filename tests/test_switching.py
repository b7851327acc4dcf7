"""The switching NMPC (Algorithm 3): its input checks, its fallback on a solver failure, and the
closed loop on the Kane model with a penalty tip contact (validation.kane_closed_loop)."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest

from controller.mode1 import ModeISettings, SolverStatus
from controller.model import UVMSModel
from controller.sqp import SQPSettings
from controller.switching import Fallback, Mode, SwitchingNMPC, SwitchingSettings
from validation.closed_loop import initial_state
from validation.kane_closed_loop import SCENARIOS, run
from validation.scenarios import wall_approach


def test_bad_state_is_rejected_in_one_line(params, scene) -> None:
    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(1.0, 0.0))
    ctl = SwitchingNMPC(model, scene.planes, ref)
    bad = h.copy()
    bad[0] = np.nan
    for x in (bad, h[:-1]):
        with pytest.raises(ValueError, match="allowed") as err:
            ctl.step(x, 0.0)
        assert "\n" not in str(err.value)


def test_solver_failure_falls_back_to_braking_within_bounds(params, scene) -> None:
    """Mode I capped at 1 SQP iteration that is not accepted as a real-time iterate fails on an
    approach at 0.3 m/s (from the held state the linearization's iterate violates the dynamics);
    the step reports the failure and the fallback and returns maximum braking (the certificate's
    rollout input): finite, within the input bounds, with surge thrust against the motion."""
    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(1.0, 0.3))
    settings = SwitchingSettings(mode1=ModeISettings(sqp=SQPSettings(max_iter=1, real_time=False)))
    ctl = SwitchingNMPC(model, scene.planes, ref, settings)
    u, info = ctl.step(h, 0.0)
    assert info.mode is Mode.I and info.status is SolverStatus.MAX_ITER and info.fallback is Fallback.GUESS
    lo, hi = params.input_bounds()
    assert np.all(np.isfinite(u)) and np.all(u >= lo) and np.all(u <= hi)
    surge = (params.allocation_matrix() @ u[:params.n_thrusters])[0]
    assert surge < -10.0  # N, braking


@pytest.mark.slow
def test_avoidable_approach_stays_in_mode_one(params) -> None:
    """0.3 m/s towards the wall 1 m ahead, thrusters working: Mode I throughout, the hull never
    closer than 0.9 m (it brakes within 0.1 m)."""
    r = run(replace(SCENARIOS["kane-avoidable"], duration=1.5))
    assert r.modes == [Mode.I]
    assert r.hull_distance.min() > 0.9


@pytest.mark.slow
def test_thruster_failure_approach_switches_through_all_modes(params) -> None:
    """Every thruster dead, 0.7 m/s towards the wall 0.38 m ahead (drag alone cannot stop it in
    time), arm stowed. Modes I -> II -> III -> I in that order; the tip touches the wall (a tip
    contact force appears) only after Mode II began; the hull stays off the wall throughout
    (distance > 0 at every 2 ms plant step); in Mode III the hull's closing speed is brought to
    >= 0 (the switch back to Mode I requires it); every planned contact force obeys
    |F_t| <= mu F_n (1e-6 N). (Mode I's arm motion alone slows the hull for a while, and on the
    smoothed model (1e-3 m, the default) the certificate finds F non-empty throughout: the switch, at
    1.5 s, is the deploy deadline's; Mode III from 1.8 s, back in Mode I at 2.0 s. On the sharp model
    IPOPT's failure on the minimum-violation problem switched at 1.5 s.)"""
    r = run(replace(SCENARIOS["kane-thrusters-dead"], duration=2.6))
    assert r.modes[:4] == [Mode.I, Mode.II, Mode.III, Mode.I]
    modes = [i.mode for i in r.infos]
    first_contact = int(np.argmax(r.tip_force_peak > 0))
    # step k's report covers its interval [t_k, t_k + dt]: a Mode II step entered with N_p = 1 ends in contact
    assert r.tip_force_peak.max() > 0 and first_contact >= modes.index(Mode.II)
    assert r.hull_distance.min() > 0
    back = next(k for k in range(1, len(modes)) if modes[k - 1] is Mode.III and modes[k] is Mode.I)
    assert r.infos[back].closing_speeds[r.infos[back].contact_plane, 0] > 0
    mu = SwitchingSettings().mode3.friction
    for i in r.infos:
        if i.mode is Mode.III and i.contact_force is not None:
            F = i.contact_force
            assert np.all(np.linalg.norm(F[:, 1:], axis=1) <= mu * F[:, 0] + 1e-6)


@pytest.mark.slow
def test_contact_check_holds_mode_three_until_the_tip_is_on_the_plane(params, scene) -> None:
    """SwitchingSettings(contact_tolerance=0.01) (the default), the controller just past Mode II's N_p = 1 step
    (Algorithm 1 hands over to Mode III), the hull 0.15 m from the wall and approaching at 0.2 m/s
    with the arm stowed: the tip, by the model's forward kinematics, is far more than 1 cm off the
    wall, so the step is Mode II's entry again (a fresh deploy plan), not Mode III. With the tip put
    on the wall by Wall_InvKin (gap below 1e-6 m) the same step is Mode III; without the setting (the
    paper, and so without `redeploy`, which would send the failed Mode III step back to Mode II) the
    far tip also goes to Mode III."""
    from controller.transcription import tip_gap

    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(0.15, 0.2))
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")

    def after_mode_two(settings: SwitchingSettings) -> SwitchingNMPC:
        ctl = SwitchingNMPC(model, scene.planes, ref, settings)
        ctl.mode, ctl._reported_mode, ctl.contact = Mode.III, Mode.II, wall  # Algorithm 1's hand-over pending
        return ctl

    checked = SwitchingSettings(contact_tolerance=0.01)
    assert float(tip_gap(model, h, scene.planes[wall])) > 0.05
    assert after_mode_two(checked).step(h, 0.0)[1].mode is Mode.II
    paper = SwitchingSettings(contact_tolerance=None, redeploy=False)  # (its Mode III solve fails: no redeploy)
    assert after_mode_two(paper).step(h, 0.0)[1].mode is Mode.III
    ctl = after_mode_two(checked)
    on = h.copy()
    on[6:6 + params.n_joints] = ctl.ocp3(wall).onto_plane(h)
    assert abs(float(tip_gap(model, on, scene.planes[wall]))) < 1e-6
    assert ctl.step(on, 0.0)[1].mode is Mode.III


@pytest.mark.slow
def test_mode_three_lets_go_only_when_mode_one_certifies_F(params, scene) -> None:
    """SwitchingSettings(certified_release=True) (opt-in), the controller in Mode III with the tip on the
    wall (Wall_InvKin) and the hull 0.3 m off, moving away at 0.1 m/s (faster than
    `separation_speed`). With working thrusters Mode I's certificate screens find a point of F, so the
    step is Mode I; oracle: the plan's inputs, re-simulated by the model's RK4 at 20 substeps per
    interval, keep every body at least 1.5 cm off every plane (Mode I's 2 cm margin less the
    4-substep re-simulation's error) and within the input bounds. With every thruster dead and a
    0.3 m/s current towards the wall no screen certifies F, so the arm keeps holding the wall (Mode
    III, the screens' UNDECIDED certificate in its StepInfo). Without the setting (the default, the
    paper's rule with a 0.05 m/s threshold) that same state leaves Mode III, Mode I's full certificate
    then finds F empty and the step re-enters Mode II: the II/III cycle that the setting removes.
    (Without `redeploy`, as the setting was measured: Mode III's cold-started solve fails in the
    stuck state, and its fallback holds the arm rigid on the wall.)"""
    from controller.feasibility import Verdict
    from controller.rollouts import simulate

    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(0.3, -0.1))
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")

    def holding(settings: SwitchingSettings) -> tuple[SwitchingNMPC, np.ndarray]:
        ctl = SwitchingNMPC(model, scene.planes, ref, settings)
        ctl.mode, ctl._reported_mode, ctl.contact = Mode.III, Mode.III, wall
        on = h.copy()
        on[6:6 + params.n_joints] = ctl.ocp3(wall).onto_plane(h)
        return ctl, on

    certified = SwitchingSettings(certified_release=True, redeploy=False)  # (as measured: Mode III holds)
    ctl, on = holding(certified)
    plane = scene.planes[wall]
    assert float(np.asarray(model.closing_speeds(on, plane.normal, plane.offset)).ravel()[0]) > 0.09
    info = ctl.step(on, 0.0)[1]
    assert info.mode is Mode.I and info.certificate.verdict is Verdict.FEASIBLE
    hs = simulate(model, on, info.u_pred, info.dt, substeps=20)
    lo, hi = params.input_bounds()
    assert np.all(info.u_pred >= lo - 1e-9) and np.all(info.u_pred <= hi + 1e-9)
    assert min(float(np.min(np.asarray(model.distances(x, p.normal, p.offset)))) for x in hs[1:]
               for p in scene.planes) > 0.015

    stuck = replace(certified, failed_thrusters=tuple(range(params.n_thrusters)), current=(0.3, 0.0, 0.0))
    ctl, on = holding(stuck)
    info = ctl.step(on, 0.0)[1]
    assert info.mode is Mode.III and info.certificate.verdict is Verdict.UNDECIDED
    ctl, on = holding(replace(stuck, certified_release=False))
    info = ctl.step(on, 0.0)[1]
    assert info.mode is Mode.II and info.switch is not None and info.certificate.verdict is Verdict.INFEASIBLE


@pytest.mark.slow
def test_background_certificate_switches_on_the_synchronous_verdict_later(params, scene) -> None:
    """SwitchingSettings(background_certificate=True) (opt-in), on an unavoidable oblique approach
    (closest body 1 cm off the wall, 0.86 m/s at 30 deg: 1.1 times F's threshold speed,
    bench/results/certificate_accuracy.md). The first step's screens find no point of F, so it stays
    in Mode I with a PENDING certificate while the minimum-violation problem runs on the worker
    thread. Once that is done, a step 0.3 s later (same state, so the oracle is exact) switches to
    Mode II on the finished verdict. Oracle: the synchronous certificate on the same state (the same
    problem from the same braking-rollout start), whose verdict and minimum violation the background
    one must equal to the bit (same arithmetic on another thread), aged by the 0.3 s."""
    from controller.feasibility import FeasibilityTest, Method, Verdict
    from controller.switching import SwitchReason
    from validation.certificate_accuracy import approach

    model = UVMSModel(params, scene.water)
    oracle = FeasibilityTest(model, scene.planes)
    h, ref = approach(oracle, 0.01, 30.0, 1.1 * 0.783)
    expected = oracle(h, ref)
    assert expected.method is Method.MINIMUM_VIOLATION and expected.verdict is Verdict.INFEASIBLE
    assert np.isfinite(expected.violation)  # a positive minimum, not an IPOPT failure

    # (without the deploy deadline, which would switch at the first step: 1 cm off at 0.86 m/s)
    ctl = SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(background_certificate=True, deploy_deadline=False,
                                                                    prebuild=False))
    u, info = ctl.step(h, 0.0)
    assert info.mode is Mode.I and info.switch is None and info.certificate.verdict is Verdict.PENDING
    assert ctl._background.busy  # the step did not wait for the problem (about 1 s)
    for _ in range(600):  # the worker's solve: about 1 s alone, allow 60 s on a loaded machine
        if not ctl._background.busy:
            break
        time.sleep(0.1)
    u, info = ctl.step(h, 0.3)
    c = info.certificate
    assert info.mode is Mode.II and info.switch is SwitchReason.F_EMPTY
    assert c.verdict is Verdict.INFEASIBLE and c.violation == expected.violation and c.age == pytest.approx(0.3)
    lo, hi = params.input_bounds()
    assert np.all(np.isfinite(u)) and np.all(u >= lo) and np.all(u <= hi)


@pytest.mark.slow
def test_background_certificate_waited_for_is_the_synchronous_verdict(params, scene) -> None:
    """SwitchingSettings(background_certificate=True, certificate_wait=...) (opt-in): a step that waits
    for the job it starts long enough (60 s here) decides on its own state, as the synchronous
    certificate does. Oracle: the synchronous controller's first step on the same unavoidable oblique
    approach (the previous test's), whose switch, verdict and minimum violation the waited-for
    background one must equal to the bit (same problem, same start, another thread), at age 0."""
    from controller.feasibility import FeasibilityTest, Verdict
    from controller.switching import SwitchReason
    from validation.certificate_accuracy import approach

    model = UVMSModel(params, scene.water)
    h, ref = approach(FeasibilityTest(model, scene.planes), 0.01, 30.0, 1.1 * 0.783)
    infos = [SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(
        background_certificate=background, certificate_wait=60.0 * background, deploy_deadline=False,
        prebuild=False)).step(h, 0.0)[1] for background in (False, True)]
    synchronous, waited = infos
    assert synchronous.mode is Mode.II and synchronous.switch is SwitchReason.F_EMPTY
    assert (waited.mode, waited.switch) == (synchronous.mode, synchronous.switch)
    assert synchronous.certificate.verdict is waited.certificate.verdict is Verdict.INFEASIBLE
    assert waited.certificate.violation == synchronous.certificate.violation and waited.certificate.age == 0.0


@pytest.mark.slow
def test_deadline_first_skips_a_question_whose_answer_changes_nothing(params, scene) -> None:
    """SwitchingSettings.deadline_first (default): on the unavoidable oblique approach above (closest
    body 1 cm off the wall at 0.86 m/s), the deploy deadline fires at the first step, so the step
    switches to Mode II whatever the minimum-violation problem would say, and it is not solved (the
    certificate stays the screens' UNDECIDED one). Oracle: the same step with the problem solved
    first (deadline_first=False), which switches on F's emptiness instead, and whose input the
    skipping step must equal to the bit (Mode II's step does not depend on the verdict)."""
    from controller.feasibility import FeasibilityTest, Method, Verdict
    from controller.switching import SwitchReason
    from validation.certificate_accuracy import approach

    model = UVMSModel(params, scene.water)
    h, ref = approach(FeasibilityTest(model, scene.planes), 0.01, 30.0, 1.1 * 0.783)
    (u_skip, skip), (u_asked, asked) = [SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(
        deadline_first=first, prebuild=False)).step(h, 0.0) for first in (True, False)]
    assert skip.mode is asked.mode is Mode.II
    assert skip.switch is SwitchReason.DEPLOY_DEADLINE and asked.switch is SwitchReason.F_EMPTY
    assert (skip.certificate.verdict, skip.certificate.method) == (Verdict.UNDECIDED, Method.SCREENS)
    assert asked.certificate.method is Method.MINIMUM_VIOLATION
    assert np.array_equal(u_skip, u_asked)


@pytest.mark.slow
def test_discarded_background_job_stops_at_its_next_iteration(params, scene) -> None:
    """BackgroundCertificate.discard (a switch, or a screen's point of F, made the job's state moot)
    stops the worker's IPOPT at its next iteration instead of letting it run on beside the steps
    that follow. Oracle: the same minimum-violation problem solved synchronously on the unavoidable
    oblique approach above, which takes 67 iterations (0.74 s) to its positive minimum; the discarded
    job ends unaccepted after fewer than half of them (measured: 0, within 12 ms), and its verdict is
    never taken."""
    from controller.background_certificate import BackgroundCertificate
    from controller.feasibility import FeasibilityTest, Method
    from controller.transcription import SolverStatus
    from validation.certificate_accuracy import approach

    test = FeasibilityTest(UVMSModel(params, scene.water), scene.planes)
    h, ref = approach(test, 0.01, 30.0, 1.1 * 0.783)
    full = test(h, ref)
    assert full.method is Method.MINIMUM_VIOLATION and full.solution.iterations >= 20
    bg = BackgroundCertificate(test)
    bg.submit(h, ref, np.zeros(3), test(h, ref, minimum_violation=False), 0.0)
    job = bg._job
    bg.discard()
    cancelled = job.result(timeout=60).solution
    assert cancelled.status is SolverStatus.FAILED and cancelled.iterations < full.solution.iterations // 2
    assert bg.take(1.0) is None and not bg.busy
