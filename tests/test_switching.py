"""The switching NMPC (Algorithm 3): its input checks, its fallback on a solver failure, and the
closed loop on the Kane model with a penalty tip contact (validation.kane_closed_loop)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from controller.mode1 import ModeISettings, SolverStatus
from controller.mode2 import ModeIIOCP
from controller.mode3 import ModeIIIOCP
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
    time: the case needs the arm), arm stowed. The run starts in Mode I and goes through Mode II to
    Mode III (the arm on the wall); the tip touches the wall (a tip contact force appears) only after
    Mode II began; the hull stays off the wall throughout (distance > 0 at every 2 ms plant step);
    every return from Mode III to Mode I comes with the hull moving away faster than
    `separation_speed` (the release rule; a failed Mode III solve alone never releases); every
    planned contact force obeys |F_t| <= mu F_n (1e-6 N). The exact mode sequence and switch times
    are not asked: they hang on the solvers' last digits."""
    r = run(replace(SCENARIOS["kane-thrusters-dead"], duration=2.6))
    modes = [i.mode for i in r.infos]
    assert modes[0] is Mode.I and Mode.II in modes and Mode.III in modes[modes.index(Mode.II):]
    first_contact = int(np.argmax(r.tip_force_peak > 0))
    # step k's report covers its interval [t_k, t_k + dt]: a Mode II step entered with N_p = 1 ends in contact
    assert r.tip_force_peak.max() > 0 and first_contact >= modes.index(Mode.II)
    assert r.hull_distance.min() > 0
    for k in range(1, len(modes)):
        if modes[k - 1] is Mode.III and modes[k] is Mode.I:
            assert r.infos[k].closing_speeds[r.infos[k].contact_plane, 0] > SwitchingSettings().separation_speed
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
def test_mode_twos_last_step_commits_its_thrust_with_the_joints_unpowered(params, scene) -> None:
    """`handover_coast` (the default): Mode II's N_p = 1 step, the tip 3 cm short of the wall and
    approaching, commits past its plan's end (StepInfo.commit_after: what strict real time applies
    should Mode III's first step come too late) one row: its plan's last thrust, the joint torques
    0. Mode II's entry step at N_p > 1 commits nothing past its plan; nor does the N_p = 1 step
    without the setting."""
    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(0.15, 0.2))
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")
    n, nt, nv = params.n_joints, params.n_thrusters, model.n_speeds
    settings = SwitchingSettings()
    q_on = SwitchingNMPC(model, scene.planes, ref, settings).ocp3(wall).onto_plane(h)
    near = h.copy()
    near[6:6 + n] = q_on + 0.69 * (h[6:6 + n] - q_on)  # the tip about 3 cm off the wall
    near[nv + 6:nv + 6 + n] = -0.5 * (h[6:6 + n] - q_on)

    def mode_two_step(x: np.ndarray, horizon: int, coast: bool):
        ctl = SwitchingNMPC(model, scene.planes, ref, replace(settings, handover_coast=coast))
        ctl.mode, ctl.contact, ctl._horizon2 = Mode.II, wall, horizon
        return ctl.step(x, 0.0)[1]

    last = mode_two_step(near, 1, coast=True)
    assert last.mode is Mode.II and last.horizon == 1
    assert last.commit_after.shape == (1, model.n_inputs)
    np.testing.assert_array_equal(last.commit_after[0, :nt], np.clip(last.u_pred[-1], *params.input_bounds())[:nt])
    np.testing.assert_array_equal(last.commit_after[0, nt:], np.zeros(n))
    assert mode_two_step(near, 1, coast=False).commit_after is None
    entry = mode_two_step(h, settings.mode2.horizon, coast=True)
    assert entry.horizon > 1 and entry.commit_after is None


@pytest.mark.slow
def test_a_tip_short_of_the_plane_but_reaching_it_by_mode_threes_first_node_hands_over(params, scene) -> None:
    """`contact_reach` (the default) under a 50 ms latency, the controller just past Mode II's
    N_p = 1 step, the check reading the state predicted 50 ms on (given as `ahead`): the arm swung
    back from its on-the-wall posture (Wall_InvKin) until the tip is 3 cm off, the hull approaching
    at 0.2 m/s and the joints turning the tip away from, slowly towards or fast towards the wall.
    The tip's gap and approach speed are measured independently of the controller's Jacobian: by
    finite differences of the gap along the model's own motion (RK4 over 1e-5 s). A tip that at
    that speed comes within the 1 cm tolerance by Mode III's first node (one 0.1 s interval after
    the measured state: 0.05 s after the predicted one) within the impact bound's speed is handed
    over to Mode III; one that moves away, or faster than the bound allows, gets Mode II afresh;
    so does every one without `contact_reach`, or without a delay."""
    from controller.transcription import tip_gap

    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(0.15, 0.2))
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")
    plane, n, nv = scene.planes[wall], params.n_joints, model.n_speeds
    joints = slice(6, 6 + n)
    settings = SwitchingSettings()
    q_on = SwitchingNMPC(model, scene.planes, ref, settings).ocp3(wall).onto_plane(h)
    back = h[joints] - q_on  # the stowed posture's direction: the gap grows along it

    def swung(s: float, speed: float) -> np.ndarray:
        x = h.copy()
        x[joints] = q_on + s * back
        x[nv + 6:nv + 6 + n] = -speed * back  # joint rates towards the wall
        return x

    s = 0.0
    while float(tip_gap(model, swung(s, 0.0), plane)) < 0.03:
        s += 0.002
    dt = 1e-5

    def measured(x: np.ndarray) -> tuple[float, float]:
        gap = float(tip_gap(model, x, plane))
        return gap, (gap - float(tip_gap(model, model.step(x, np.zeros(model.n_inputs), dt), plane))) / dt

    latency = 0.05

    def mode_after(x: np.ndarray, reach: bool, lead: float | None = latency) -> tuple[Mode, Fallback]:
        ctl = SwitchingNMPC(model, scene.planes, ref, replace(settings, contact_reach=reach))
        ctl.mode, ctl._reported_mode, ctl.contact = Mode.III, Mode.II, wall  # Algorithm 1's hand-over pending
        info = ctl.step(x, -latency, None if lead is None else (x, 0.0))[1]  # x: as if predicted at t + L
        return info.mode, info.fallback

    ocp2 = SwitchingNMPC(model, scene.planes, ref, settings).ocp2(wall)
    tol, first_node = settings.contact_tolerance, settings.mode3.dt
    decided = []
    for rate in (-0.2, 0.5, 4.0):  # along `back` [1/s]: turning away, reaching, beyond the impact bound
        x = swung(s, rate)
        gap, speed = measured(x)
        allowed = ocp2.allowed_speed(x)
        reaches = 0.0 < speed <= allowed and gap <= tol + speed * (first_node - latency)
        margin = min(abs(gap - tol - speed * (first_node - latency)), abs(speed - allowed))
        assert gap > tol and margin > 0.005, (gap, speed, allowed)  # far from the rule's edges
        mode, fallback = mode_after(x, reach=True)
        handed_over = mode is Mode.III or fallback is Fallback.REDEPLOY  # (its first solve may fail)
        assert handed_over == reaches, (rate, gap, speed, allowed)
        assert mode_after(x, reach=False)[0] is Mode.II
        assert mode_after(x, reach=True, lead=None)[0] is Mode.II
        decided.append(reaches)
    assert decided == [False, True, False]  # each branch of the rule met once


def test_mode_three_plans_over_its_thrust_horizon_only_while_a_thruster_lives(params, scene) -> None:
    """mode3.thrust_horizon=3, the tip put on the wall by Wall_InvKin: with live thrusters Mode III's
    step plans 3 intervals (its plan has 3 inputs and 4 states); once every thruster is known dead
    the same step plans `mode3.horizon` (5) intervals, whose problem pins every thrust to 0."""
    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(0.15, 0.2))
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")
    settings = SwitchingSettings()
    ctl = SwitchingNMPC(model, scene.planes, ref, replace(settings, mode3=replace(settings.mode3, thrust_horizon=3)))
    on = h.copy()
    on[6:6 + params.n_joints] = ctl.ocp3(wall).onto_plane(h)
    for failed, horizon in (((), 3), (tuple(range(params.n_thrusters)), 5)):
        ctl.set_failed_thrusters(failed)
        ctl.mode, ctl._reported_mode, ctl.contact = Mode.III, Mode.II, wall
        u, info = ctl.step(on, 0.0)
        assert info.mode is Mode.III and info.horizon == horizon
        assert info.u_pred.shape[0] == horizon and info.h_pred.shape[0] == horizon + 1
        if failed:
            assert np.all(u[:params.n_thrusters] == 0.0)


def test_under_a_latency_mode_three_enters_over_two_intervals_and_the_held_plan_starts_the_next_step(
        params, scene) -> None:
    """The hull 0.15 m from the wall closing at 0.2 m/s, thrusters working (Mode III plans 3 intervals),
    the tip put on the wall by Wall_InvKin; Mode III's first step under a 50 ms latency. Oracle 1: the
    two-interval problem, built and solved here from Algorithm 2's guess; the step's plan must be its
    plan over those intervals to 1e-9, then its last input and force held (the same rows). Oracle 2:
    the step after, at the plan's node after one interval, started from that plan, must end where a
    cold three-interval solve there from Algorithm 2's guess ends: cost within 1e-3 of it (IPOPT stops at
    its acceptable level, dual infeasibility 1e-2) and first input within 2 % of its largest, in fewer
    iterations. Oracle 3: without a latency the first step is the cold three-interval solve, to 1e-9."""
    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(0.15, 0.2))
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")
    ctl = SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(mode3_step_helper=False))
    ocp = ctl.ocp3(wall)
    N = ocp.settings.horizon
    on = h.copy()
    on[6:6 + params.n_joints] = ocp.onto_plane(h)
    held = np.repeat(ctl.last_u[None], N, 0)

    def first_step(latency: float):
        ctl.latency, ctl._plan, ctl.last_u = latency, None, np.zeros(params.n_inputs)
        ctl.mode, ctl._reported_mode, ctl.contact = Mode.III, Mode.II, wall
        _, info = ctl.step(on, 0.0)
        assert info.mode is Mode.III and info.status.usable and info.horizon == N
        return info

    info = first_step(0.05)
    short = ModeIIIOCP(model, scene.planes, wall, replace(ocp.settings, horizon=2))
    short.limit_inputs(ctl.lo, ctl.hi)
    two = short.solve(on, short.contact_guess(on, held[:2], None, ctl.current), ctl.current)
    assert two.status.usable and info.iterations == two.iterations
    np.testing.assert_allclose(info.u_pred, np.vstack([two.u, two.u[-1:]]), rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(ctl._plan.force, np.vstack([two.force, two.force[-1:]]), rtol=0.0, atol=1e-9)

    nxt = ctl._recomputed[1].copy()
    cold = ocp.solve(nxt, ocp.contact_guess(nxt, held, None, ctl.current), ctl.current)
    _, second = ctl.step(nxt, ocp.settings.dt)
    assert cold.status.usable and second.status.usable
    assert abs(ctl._plan.cost - cold.cost) < 1e-3
    scale = float(np.max(np.abs(cold.u[0])))
    np.testing.assert_allclose(second.u_pred[0], cold.u[0], rtol=0.0, atol=0.02 * scale)
    assert second.iterations < cold.iterations

    info = first_step(0.0)
    full = ocp.solve(on, ocp.contact_guess(on, held, None, ctl.current), ctl.current)
    np.testing.assert_allclose(ctl._plan.w, full.w, rtol=0.0, atol=1e-9)


def test_under_a_latency_the_first_mode_one_step_solves_the_next_plan_from_the_predicted_state(
        params, scene) -> None:
    """wall-headon's start (horizontal thrusters dead, 0.25 m/s current onto the wall) under a 50 ms
    latency: the first step certifies F by the minimum-violation problem and its input acts at once,
    held until the next step's answer acts 0.15 s later. With `first_step_solves_next` that step's own
    input is unchanged to the bit. Oracle 1: the plan kept for the next step starts at the model's
    RK4 state after that input held 0.15 s in 150 substeps, to 5e-4 (the 4-substep prediction's own
    truncation error is 3e-5 here; the planner's clearance margin is 2 cm). Oracle 2: its inputs,
    re-simulated from there in 150 substeps per interval (not the screens' 4), keep every body above
    the margin within the bounds. Oracle 3: the next step, at that state (a plant that is the model),
    is certified by that plan (the screens' previous plan) and solves Mode I in the real-time budget;
    without the setting the same step needs the SQP continued by its line search."""
    from controller.feasibility import Method
    from controller.model import water
    from controller.rollouts import simulate
    from validation import scenarios

    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, scenarios.get("wall-headon"))
    steps = {}
    for ahead in (True, False):
        ctl = SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(first_step_solves_next=ahead))
        ctl.set_failed_thrusters((0, 1, 2, 3))
        ctl.current, ctl.latency = water([0.25, 0.0, 0.0]), 0.05
        u0, first = ctl.step(h, 0.0)
        assert first.mode is Mode.I and first.certificate.method is Method.MINIMUM_VIOLATION
        fine = model.held_steps(h, u0, 0.15, 150, vc=ctl.current)
        if ahead:
            kept = ctl._plan
            np.testing.assert_allclose(kept.h[0], fine, rtol=0.0, atol=5e-4)
            hs = simulate(model, fine, kept.u, ctl.settings.mode1.dt, substeps=150, current=ctl.current)
            assert ctl.feasibility.plan_is_feasible(hs, kept.u)
        _, second = ctl.step(model.held_steps(h, u0, 0.1, 100, vc=ctl.current), 0.1, ahead=(fine, 0.15))
        steps[ahead] = (u0, second)
    np.testing.assert_array_equal(steps[True][0], steps[False][0])
    on, off = steps[True][1], steps[False][1]
    assert on.mode is Mode.I and on.certificate.method is Method.PREVIOUS_PLAN
    assert on.iterations <= ctl.settings.mode1.sqp.max_iter
    assert off.mode is Mode.I and off.certificate.method is Method.REFINED_PLAN


@pytest.mark.parametrize("latency", [0.0, 0.05])
def test_under_a_latency_mode_threes_problems_are_built_before_the_first_step(params, scene, latency) -> None:
    """A step under a latency pays for what it builds: Mode III's problem with its angles regular at
    90 deg of pitch (`regular_pitch`), built when a hull first pitched past 75 deg, cost 85-95 ms in
    the middle of arm-deployed runs. Reset under a latency, the controller holds Mode III's problem
    against every plane over both of its horizons (3 intervals while a thruster lives, 5 once every
    one is dead) and over its entry's 2 (`mode3_entry_intervals`), with both pitched twins, before
    its first step; without one, only what its first Mode III step would use (built at construction)."""
    from controller.protocol import Task
    from controller.switching import SwitchingController

    h, ref = initial_state(params, wall_approach(1.0, 0.3))
    ctl = SwitchingController(SwitchingSettings(mode2_entry_helper=False))
    ctl.reset(Task("prepared", params, scene, h, lambda t: ref, latency=latency))
    planes = range(len(scene.planes))
    built = {key: set(ocp._twins) for key, ocp in ctl.nmpc._mode3.items()}
    if latency:
        assert built == {(p, n): {1.0, -1.0} for p in planes for n in (2, 3, 5)}
    else:
        assert built == {(p, 3): set() for p in planes}


@pytest.mark.slow
def test_the_deploy_deadline_skips_a_question_whose_answer_changes_nothing(params, scene) -> None:
    """On an unavoidable oblique approach (closest body 1 cm off the wall at 0.86 m/s, 30 deg: 1.1
    times the speed at which the labelled braking ground truth says F empties,
    validation.approaches), the deploy deadline fires at the first step: the step switches to Mode
    II and neither Mode I's problem nor the minimum-violation problem is solved (the certificate
    stays the braking rollout's UNDECIDED one; the solves are counted by `on_solve`). Oracle: the
    same step without the deadline, which must solve the problem and also switch (F is empty here,
    so no RK4-checked witness can exist: a positive minimum or an IPOPT failure, either way a
    switch), and whose input the skipping step must equal to the bit (Mode II's first step depends
    on the braking rollout's plane, not on the verdict)."""
    from controller.feasibility import FeasibilityTest, Method, Verdict
    from controller.switching import SwitchReason
    from validation.approaches import OBLIQUE_1CM_THRESHOLD, approach

    model = UVMSModel(params, scene.water)
    h, ref = approach(FeasibilityTest(model, scene.planes), 0.01, 30.0, 1.1 * OBLIQUE_1CM_THRESHOLD)
    rollouts = []
    original = ModeIIOCP.deploy_guess

    def counted(self, *args, **kwargs):
        rollouts.append(args[1])
        return original(self, *args, **kwargs)

    solved: dict[bool, list[str]] = {True: [], False: []}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(ModeIIOCP, "deploy_guess", counted)
        (u_skip, skip), (u_asked, asked) = [SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(
            deploy_deadline=deadline), on_solve=lambda e, d=deadline: solved[d].append(e.kind)).step(h, 0.0)
            for deadline in (True, False)]
    assert len(rollouts) == 2  # once in each step: Mode II's entry reuses the deadline's deploy rollout
    assert solved[True] == ["mode2"]
    assert {"mode1", "certificate", "mode2"} <= set(solved[False])
    assert skip.mode is asked.mode is Mode.II
    assert skip.switch is SwitchReason.DEPLOY_DEADLINE
    assert asked.switch in (SwitchReason.F_EMPTY, SwitchReason.SOLVER_FAILURE)
    assert (skip.certificate.verdict, skip.certificate.method) == (Verdict.UNDECIDED, Method.SCREENS)
    assert (asked.certificate.verdict, asked.certificate.method) == (Verdict.INFEASIBLE, Method.MINIMUM_VIOLATION)
    assert np.array_equal(u_skip, u_asked)


def test_the_deploy_deadline_reads_the_deploy_rollouts_own_time_to_contact(params, scene) -> None:
    """Under a 50 ms latency Mode II's intervals are 0.05-0.1 s long (SwitchingController), so its
    entry guess's N_p dt rounds the deploy rollout's time to contact up to a whole number of 0.05 s;
    the deadline compares with the time itself. On wall-headon's approaches (horizontal thrusters
    dead, 0.25 m/s of current onto the wall; the stowed arm's base 0.10 to 0.25 m off the wall at 0.5
    to 0.9 m/s), the deadline fires exactly when the rule of its docstring
    says with t_c the time the deploy policy, stepped in numpy every 0.01 s from the state (the
    oracle of tests/test_rollouts.py), first puts the tip on the wall, and the rounded time decides
    differently on at least one of them (so the test tells the two apart)."""
    from types import SimpleNamespace

    from controller.feasibility import FeasibilityTest
    from controller.mode2 import ModeIISettings
    from controller.model import water
    from controller.transcription import tip_gap
    from validation.approaches import approach

    model = UVMSModel(params, scene.water)
    m2 = ModeIISettings(dt_nominal=0.05, dt_bounds=(0.05, 0.1))
    settings = SwitchingSettings(mode2=m2)
    test = FeasibilityTest(model, scene.planes)
    decided, rounded_differs = 0, 0
    for gap in (0.10, 0.15, 0.20, 0.25):
        for speed in (0.5, 0.7, 0.9):
            h, ref = approach(test, gap, 0.0, speed)
            nmpc = SwitchingNMPC(model, scene.planes, ref, settings)
            nmpc.set_failed_thrusters((0, 1, 2, 3))
            nmpc.current = water([0.25, 0.0, 0.0])
            hs, _ = nmpc.feasibility.braking_rollout(h, nmpc.current)
            ocp2 = nmpc.ocp2(nmpc._closest_plane(hs))
            margin = nmpc.feasibility.settings.distance_margin
            close = [ocp2.protected_clearance(x) < margin for x in hs[1:]]
            if not any(close):
                continue
            cert = SimpleNamespace(rollout=hs, rollout_clearance=-1.0)
            fired = nmpc._deadline(h, cert)
            posture, x, t_c = ocp2.reach(h), h, None
            for i in range(m2.horizon * 10):
                x = model.step(x, ocp2.deploy(x, posture, nmpc.current), 0.01, vc=nmpc.current)
                if float(tip_gap(model, x, ocp2.planes[ocp2.contact])) <= 0.0:
                    t_c = (i + 1) * 0.01
                    break
            assert t_c is not None
            t_hit, period, lead = 0.1 * (1 + close.index(True)), 0.1, settings.deadline_lead
            assert fired == (t_hit <= t_c + period + lead + 1e-9), (gap, speed, t_c, t_hit)
            _, us, dt = ocp2.deploy_guess(h, m2.horizon, nmpc.current)
            rounded_differs += (t_hit <= len(us) * dt + period + lead + 1e-9) != fired
            decided += 1
    assert decided >= 10 and rounded_differs >= 1, (decided, rounded_differs)


@pytest.mark.slow
def test_every_solve_is_reported_to_the_hook(params, scene) -> None:
    """`on_solve`: every optimal-control solve of a step is reported once, with its problem and its
    solution. Oracle: the step's own StepInfo (Mode I's solve is its OCP time and iterations), and
    the certificate's minimum-violation problem, reported on the unavoidable approach above without
    the deadline (where the screens fail, so it must be solved)."""
    from controller.feasibility import FeasibilityTest
    from validation.approaches import OBLIQUE_1CM_THRESHOLD, approach

    model = UVMSModel(params, scene.water)
    events = []
    h, ref = initial_state(params, wall_approach(1.0, 0.3))
    ctl = SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(), on_solve=events.append)
    info = ctl.step(h, 0.0)[1]
    assert [e.kind for e in events] == ["mode1"]
    assert events[0].solution.iterations == info.iterations and events[0].solution.solve_time == info.ocp_time
    events.clear()
    h, ref = approach(FeasibilityTest(model, scene.planes), 0.01, 30.0, 1.1 * OBLIQUE_1CM_THRESHOLD)
    ctl = SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(deploy_deadline=False), on_solve=events.append)
    ctl.step(h, 0.0)
    kinds = [e.kind for e in events]
    assert "certificate" in kinds and kinds[-1] == "mode2"


@pytest.mark.parametrize("told, wall_clock", [(0.05, False), (0.0, True)])
def test_with_a_latency_each_step_plans_from_the_predicted_state(params, scene, told, wall_clock) -> None:
    """Task latency 0.05 s (or none told in a loop on the wall clock: `assumed_latency`, 0.05 s, which
    a loop where the plant waits never gets, nor one that tells its own), 0.3 m/s towards
    the wall 1 m ahead with a 0.1 m/s current (Mode I): the first step plans from the measured
    state (its input acts at once); the second from the state 0.05 s later under the first step's
    input held, which is what acts during the delay. Oracle: the model's RK4 in 200 substeps of
    0.25 ms from the measured state under that input and current, against the plan's first node
    (4 substeps of 12.5 ms). Tolerance 1e-6 (m, rad, m/s, rad/s): RK4's error at 12.5 ms on this
    motion is below 1e-8; anything from the wrong input, the wrong time or no prediction at all is
    above 1e-3. Mode II's interval range is scaled to start at the latency (the default's (0.025,
    0.05) s to (0.05, 0.1) s), and a latency longer than Mode I's interval is refused in one line."""
    from controller.protocol import Task
    from controller.switching import SwitchingController

    model = UVMSModel(params, scene.water, SwitchingSettings().model_options())  # the controller's own model
    h, ref = initial_state(params, wall_approach(1.0, 0.3))
    from uvms.scene import Current
    water = scene.with_current(Current.constant((0.1, 0.0, 0.0)))
    task = Task("latency", params, water, h, lambda t: ref, latency=told, wall_clock=wall_clock)
    for other, planned in ((replace(task, latency=0.0, wall_clock=False), 0.0), (replace(task, latency=0.02), 0.02)):
        if wall_clock:  # the delay planned for: none where the plant waits, the told one where told
            ctl = SwitchingController(SwitchingSettings(mode2_entry_helper=False))
            ctl.reset(other)
            assert ctl.latency == planned
    ctl = SwitchingController(SwitchingSettings(mode2_entry_helper=False, release_at_latency=False))
    ctl.reset(task)
    assert ctl.latency == 0.05
    assert ctl.nmpc.settings.mode2.dt_bounds == (0.05, 0.1) and ctl.nmpc.settings.mode2.dt_nominal == 0.05
    u0, info0 = ctl.step(h, 0.0)
    assert info0.mode is Mode.I and np.array_equal(info0.h_pred[0], h)
    h1 = model.held_steps(h, u0, 0.1, 400, vc=np.array([0.1, 0.0, 0.0]))  # the plant, held input
    _, info1 = ctl.step(h1, 0.1)
    fine = model.held_steps(h1, u0, 0.05, 200, vc=np.array([0.1, 0.0, 0.0]))
    assert info1.t == 0.1 and info1.mode is Mode.I
    np.testing.assert_allclose(info1.h_pred[0], fine, atol=1e-6)
    assert np.max(np.abs(fine - h1)) > 1e-3  # the prediction is not the measured state
    with pytest.raises(ValueError, match="allowed") as err:
        SwitchingController(SwitchingSettings(assumed_latency=0.15)).reset(replace(task, latency=0.0, wall_clock=True))
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("told, wall_clock, slow, waits", [
    (0.0, True, 0.0, 0.05), (0.0, True, 0.08, 0.0), (0.05, True, 0.0, 0.0), (0.0, False, 0.0, 0.0)],
    ids=["measured delay, fast step", "measured delay, slow step", "told delay", "plant waits"])
def test_release_at_latency_waits_only_where_the_loop_does_not(params, scene, monkeypatch, told, wall_clock, slow,
                                                               waits) -> None:
    """`release_at_latency` with 0.05 s assumed: on a fake clock that only the step's own computation
    (`slow` seconds, added to Mode I's step) and its waits advance, the second step of a loop on the
    wall clock that tells no delay (a measured one) returns 0.05 s after its call, waiting what its
    computation left; a slower step returns at once; a loop that keeps a told delay itself, or a
    plant that waits, is never waited for; the first step (acting at once) never waits."""
    import controller.switching as switching
    from controller.protocol import Task

    clock, slept = [0.0], []

    class FakeTime:
        @staticmethod
        def perf_counter() -> float:
            return clock[0]

        @staticmethod
        def sleep(seconds: float) -> None:
            slept.append(seconds)
            clock[0] += seconds

    monkeypatch.setattr(switching, "time", FakeTime)
    h, ref = initial_state(params, wall_approach(1.0, 0.3))
    task = Task("release", params, scene, h, lambda t: ref, latency=told, wall_clock=wall_clock)
    ctl = switching.SwitchingController(SwitchingSettings(assumed_latency=0.05))
    ctl.reset(task)
    step1 = ctl.nmpc._step_mode1

    def computing(*args, **kwargs):
        clock[0] += slow
        return step1(*args, **kwargs)

    ctl.nmpc._step_mode1 = computing
    ctl.step(h, 0.0)
    assert sum(slept) == 0.0
    start = clock[0]
    assert ctl.step(h, 0.1)[1].mode is Mode.I
    assert sum(slept) == pytest.approx(waits, abs=1e-12)
    assert clock[0] - start == pytest.approx(max(slow, waits), abs=1e-12)


def test_a_failed_solve_returns_and_reports_the_shifted_plan(params, scene) -> None:
    """Mode I plans on an avoidable approach; its next solve is made to fail: the step's input is
    the previous plan's second input, and the plan it reports (what the strict real-time loop
    commits to, validation.closed_loop) is the previous plan shifted by one interval, so that its
    first row is the input returned and its next row the one after (oracle: the first plan)."""
    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(1.0, 0.3))
    ctl = SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(switching=False))
    _, first = ctl.step(h, 0.0)
    solve = ctl.mode1.solve
    ctl.mode1.solve = lambda *a, **k: replace(solve(*a, **k), status=SolverStatus.FAILED)
    u, info = ctl.step(first.h_pred[1], 0.1)
    assert info.fallback is Fallback.SHIFTED_PLAN
    np.testing.assert_array_equal(u, np.clip(first.u_pred[1], *params.input_bounds()))
    np.testing.assert_array_equal(info.u_pred, first.u_pred[1:])


@pytest.mark.slow
def test_a_continued_plan_is_mode_ones_plan_and_a_point_of_F() -> None:
    """A certificate call recorded in a MuJoCo closed loop (wall-oblique, mismatch seed 1, the
    horizontal thrusters dead, hull near the wall): the braking rollout fails and Mode I's
    real-time plan from the held state is no point of F, so the step continues that plan by the SQP
    with the line search (up to 16 iterations here, for margin over the 2-5 it takes on this
    machine) and certifies F with it (REFINED_PLAN), without the minimum-violation problem. That
    plan is the step's: oracle, its inputs re-simulated from the state by RK4 at 20 substeps an
    interval keep every body the margin off the walls within the bounds (plan_is_feasible), the
    plan's states are its inputs' own 4-substep re-simulation, and the input returned is its first
    (clipped to the bounds)."""
    from pathlib import Path

    from controller.feasibility import CertificateSettings, Method, Verdict
    from controller.rollouts import simulate
    from validation import mismatch, scenarios
    from validation.closed_loop import build_plant

    params, scene, _, _ = build_plant(scenarios.get("wall-oblique"), mismatch.DEFAULT, 1)
    model = UVMSModel(params, scene.water)
    rec = dict(np.load(Path(__file__).parent / "data" / "wall_oblique_certificate_call.npz"))
    failed = tuple(int(i) for i in np.flatnonzero((rec["input_lo"] == 0) & (rec["input_hi"] == 0)))
    settings = SwitchingSettings(failed_thrusters=failed, current=tuple(rec["current"]),
                                 certificate=CertificateSettings(refine_iterations=16))
    ctl = SwitchingNMPC(model, scene.planes, rec["h_ref"], settings)
    h0 = rec["h0"]
    assert not ctl.feasibility.plan_is_feasible(*ctl.feasibility.braking_rollout(h0, ctl.current))
    u, info = ctl.step(h0, 0.0)
    assert (info.mode, info.certificate.method, info.certificate.verdict) == (Mode.I, Method.REFINED_PLAN,
                                                                            Verdict.FEASIBLE)
    assert info.status is SolverStatus.STOPPED and info.fallback is Fallback.NONE
    dt, current = settings.mode1.dt, ctl.current
    np.testing.assert_array_equal(info.h_pred, simulate(model, h0, info.u_pred, dt, current=current))
    assert ctl.feasibility.plan_is_feasible(simulate(model, h0, info.u_pred, dt, substeps=20, current=current),
                                            info.u_pred)
    np.testing.assert_array_equal(u, np.clip(info.u_pred[0], ctl.lo, ctl.hi))  # (the QP's 1e-16 on dead thrusters)
