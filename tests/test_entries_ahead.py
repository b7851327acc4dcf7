"""Mode entries solved ahead in a forked helper process (controller.entries_ahead)."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest

from controller.entries_ahead import ContactEntry, ContactStep, DeployEntry
from controller.model import UVMSModel, water
from controller.switching import Mode, SwitchingNMPC, SwitchingSettings
from validation.closed_loop import initial_state
from validation.scenarios import wall_approach

WAIT = 120.0  # s: how long the test waits for the helper's answer before calling it lost (not a timing check)


def _answered(ctl, request):
    """Submit `request` to the controller's helper and wait (up to WAIT) for its answer's solution."""
    ctl._helper.submit(request)
    answer, t0 = None, time.monotonic()
    while answer is None and time.monotonic() - t0 < WAIT:
        time.sleep(0.02)
        answer = ctl._helper.take(type(request), request.plane, request.horizon)
    assert answer is not None, "the helper never answered"
    return answer[1]


def test_the_helpers_entry_is_the_solve_in_this_process_and_starts_mode_three_at_it(params, scene) -> None:
    """Every thruster dead, the hull 0.15 m from the wall closing at 0.2 m/s, the tip put on the wall
    by Wall_InvKin. Oracle 1: the same Mode III problem solved in this process from Algorithm 2's
    guess; the forked helper's answer must be that plan to 1e-9 (same code, same data: only the
    transport differs). Oracle 2: Mode III's first step from that answer, at the state it was solved
    for, must return the helper's plan again, to 1e-3 of its largest input (IPOPT's warm start stops at
    its acceptable level, constraints 1e-5), in fewer iterations than the cold solve took."""
    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(0.15, 0.2))
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")
    ctl = SwitchingNMPC(model, scene.planes, ref)
    ctl.set_failed_thrusters(tuple(range(params.n_thrusters)))
    on = h.copy()
    on[6:6 + params.n_joints] = ctl.ocp3(wall).onto_plane(h)
    ocp, current = ctl.ocp3(wall), water(np.zeros(3))
    request = ContactEntry(wall, ocp.settings.horizon, on, np.zeros(params.n_inputs), current, ctl.lo, ctl.hi)
    ctl.start_entry_helper()
    try:
        answer = _answered(ctl, request)
        held = np.zeros((ocp.settings.horizon, params.n_inputs))
        here = ocp.solve(on, ocp.contact_guess(on, held, None, current), current)
        assert here.status.usable
        np.testing.assert_allclose(answer.w, here.w, rtol=0.0, atol=1e-9)

        ctl._helper._answers[ContactEntry] = (request, answer)
        ctl.settings = replace(ctl.settings, mode3_entry_helper=True)
        ctl.mode, ctl._reported_mode, ctl.contact, ctl.current = Mode.III, Mode.II, wall, current
        _, info = ctl.step(on, 0.0)
        assert info.mode is Mode.III and info.status.usable
        scale = float(np.max(np.abs(answer.u)))
        np.testing.assert_allclose(info.u_pred, answer.u, rtol=0.0, atol=1e-3 * scale)
        assert info.iterations < here.iterations
    finally:
        ctl.close()


def test_the_helpers_deploy_is_the_solve_in_this_process_and_starts_mode_two_at_it(params, scene) -> None:
    """An unavoidable head-on approach (1.2 m/s, the hull 0.4 m from the wall, thrusters working).
    Oracle 1: Mode II's problem solved in this process from its deploy guess; the forked helper's
    answer to the same DeployEntry must be that plan to 1e-9 (same code, same data: only the
    transport differs). Oracle 2: Mode II's first step at that state and time, started from the
    answer and its multipliers, must end at the optimum a solve without multipliers from the same
    start reaches (the problem's parameters come from its start: its last node's allowed speed), its
    cost to 1e-5 (the redundant thrusters make the inputs' optimum flat: they differ by up to 0.6 %),
    in fewer iterations than the solve from the deploy guess took; an answer for a state more than
    half a Mode I period older is not taken (the deploy guess's solve is)."""
    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(0.4, 1.2))
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")
    ctl = SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(mode2_entry_helper=True))
    N, current = ctl.settings.mode2.horizon, water(np.zeros(3))
    ocp = ctl.ocp2(wall)
    request = DeployEntry(wall, N, h, 0.3, current, ctl.lo, ctl.hi)
    ctl.start_entry_helper()
    try:
        answer = _answered(ctl, request)
        here = ocp.solve(h, ocp.deploy_guess(h, N, current), current)
        assert here.status.usable
        np.testing.assert_allclose(answer.w, here.w, rtol=0.0, atol=1e-9)

        ctl.mode, ctl.contact, ctl.current, ctl._t = Mode.II, wall, current, 0.3
        ctl._helper._answers[DeployEntry] = (request, answer)
        sent, submit = [], ctl._helper.submit
        ctl._helper.submit = lambda entry: sent.append(type(entry)) or submit(entry)
        out = ctl._step_mode2(h)
        assert out.status.usable
        assert ContactEntry not in sent  # Mode III's entry is not asked for without mode3_entry_helper
        start = (np.vstack([h, answer.h[1:]]), answer.u, answer.dt)
        cold = ocp.solve(h, start, current)  # the same problem (its parameters come from the start) without duals
        assert cold.status.usable
        assert abs(ctl._plan.cost - cold.cost) <= 1e-5 * abs(cold.cost)  # the same optimum (thrust allocation is flat)
        assert out.iterations < here.iterations

        ctl.mode, ctl._plan, ctl._horizon2, ctl._t = Mode.II, None, N, 0.3 + 0.6 * ctl.settings.mode1.dt
        ctl._helper._answers[DeployEntry] = (request, answer)
        assert ctl._step_mode2(h).iterations == here.iterations
    finally:
        ctl.close()


def test_the_helpers_next_mode_three_step_is_the_solve_in_this_process_and_starts_that_step(params, scene) -> None:
    """The entry of the test above, Mode III's first step taken in the controller with
    `mode3_step_helper`, which sends its plan to the helper. Oracle 1: Mode III's problem solved in
    this process from the plan's next node (its recomputed states), warm from the plan shifted and its
    multipliers, which is also the solve the next step would make from the shifted plan at that
    state; the helper's answer must be that plan to 1e-9 (same code, same data: only the transport
    differs). Oracle 2: the next step, measured at that node and started from the answer, returns the
    answer's plan to 1e-3 of its largest input (IPOPT's warm start stops at its acceptable level) in
    fewer iterations than the solve from the shifted plan took. Oracle 3: an answer that continues an
    older plan is not taken: that step is the solve from its own shifted plan, to 1e-9."""
    model = UVMSModel(params, scene.water)
    h, ref = initial_state(params, wall_approach(0.15, 0.2))
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")
    ctl = SwitchingNMPC(model, scene.planes, ref, SwitchingSettings(mode3_step_helper=True))
    ctl.set_failed_thrusters(tuple(range(params.n_thrusters)))
    ocp, current = ctl.ocp3(wall), water(np.zeros(3))
    N = ocp.settings.horizon
    on = h.copy()
    on[6:6 + params.n_joints] = ocp.onto_plane(h)

    def from_shifted(plan, states):
        """The solve a Mode III step at states[1] makes from the shifted plan (the Final Algorithm)."""
        guess = ocp.pack(np.vstack([states[1:], states[-1:]]), np.vstack([plan.u[1:], plan.u[-1:]]),
                         np.vstack([plan.force[1:], plan.force[-1:]]))
        return ocp.solve(states[1], guess, current, ocp.shifted_duals(plan))

    ctl.start_entry_helper()
    try:
        ctl.mode, ctl._reported_mode, ctl.contact, ctl.current = Mode.III, Mode.II, wall, current
        _, first = ctl.step(on, 0.0)
        assert first.mode is Mode.III and first.status.usable
        plan, states = ctl._plan, ctl._recomputed.copy()
        answer, t0 = None, time.monotonic()
        while answer is None and time.monotonic() - t0 < WAIT:
            time.sleep(0.02)
            answer = ctl._helper.take(ContactStep, wall, N)
        assert answer is not None, "the helper never answered"
        assert answer[0].plan_index == ctl._mode3_plans
        here = from_shifted(plan, states)
        assert here.status.usable
        np.testing.assert_allclose(answer[1].w, here.w, rtol=0.0, atol=1e-9)

        ctl._helper._answers[ContactStep] = answer
        _, info = ctl.step(states[1], ocp.settings.dt)
        assert info.mode is Mode.III and info.status.usable
        scale = float(np.max(np.abs(answer[1].u)))
        np.testing.assert_allclose(info.u_pred, answer[1].u, rtol=0.0, atol=1e-3 * scale)
        assert info.iterations < here.iterations

        ctl.close()  # a helper that hands back only the stale answer
        plan, states = ctl._plan, ctl._recomputed.copy()
        ctl._helper = type("Stale", (), {"take": lambda self, *a: answer, "submit": lambda self, r: None,
                                         "close": lambda self: None})()
        expected = from_shifted(plan, states)
        ctl.step(states[1], 2 * ocp.settings.dt)
        np.testing.assert_allclose(ctl._plan.w, expected.w, rtol=0.0, atol=1e-9)
    finally:
        ctl.close()


@pytest.mark.parametrize(("latency", "wall_clock", "started"), [(0.05, True, True), (0.05, False, False),
                                                                  (0.0, True, True), (0.0, False, False)])
def test_the_helper_runs_only_under_a_latency_on_the_wall_clock(params, scene, latency, wall_clock, started) -> None:
    """The helper is not deterministic (which answer comes back in time depends on the machine), so
    the controller starts it only where the loop's timing already decides what is late: a latency
    in a loop paced at the wall clock, told (strict) or not (measured: the assumed one). A fixed
    delay the plant waits out, or no delay, stays deterministic."""
    from controller.protocol import Task
    from controller.switching import SwitchingController

    h, ref = initial_state(params, wall_approach(0.4, 1.2))
    ctl = SwitchingController()
    ctl.reset(Task("helper", params, scene, h, lambda t: ref, latency=latency, wall_clock=wall_clock))
    try:
        assert (ctl.nmpc._helper is not None) is started
    finally:
        ctl.nmpc.close()
