"""The asynchronous wrapper (controller.asynchronous): which plan row each step returns, against the
plans the inner controller made (a scripted inner controller whose answers the test releases), and
the switching NMPC's answers through the worker against the same controller stepped in this process."""

from __future__ import annotations

import multiprocessing as mp
from dataclasses import replace

import numpy as np
import pytest

from controller.asynchronous import Asynchronous, AsyncSettings, Following
from controller.protocol import StepInfo, Task

NU, DT = 3, 0.1


class Scripted:
    """A controller whose plan at request time t has rows [t, k, 0] (k = 0..4, each DT long); each
    step after the first waits for `release` (shared with the forked worker)."""

    def __init__(self, release: mp.synchronize.Event, fail: bool = False):
        self.release, self.fail, self.told, self.calls = release, fail, None, 0

    def reset(self, task: Task) -> None:
        self.told = task.latency

    def step(self, h: np.ndarray, t: float) -> tuple[np.ndarray, StepInfo]:
        self.calls += 1
        if self.calls > 1:
            self.release.wait(10.0)
            if self.fail:
                raise ArithmeticError("scripted failure")
        rows = np.array([[t, k, 0.0] for k in range(5)])
        return rows[0], StepInfo(t=t, dt=DT, mode="I", fallback="none", solve_time=0.5, u_pred=rows)


def task(latency: float) -> Task:
    return Task("scripted", None, None, np.zeros(2), lambda t: np.zeros(2), latency=latency)  # type: ignore[arg-type]


def test_steps_follow_each_plan_by_time_and_take_answers_when_they_act() -> None:
    """L = 0.02 s, lead 0.05 s. The first answer acts at once (plan start 0); the request of 0.05 s
    gives a plan starting at 0.10 s. An answer in before its start waits (the first plan acts
    meanwhile); from its start each step returns the row acting at t + L, the last one once the plan
    has run out, while the worker is held on the next request."""
    release = mp.get_context("fork").Event()
    inner = Scripted(release)
    ctl = Asynchronous(inner, AsyncSettings(lead=0.05, period=0.05))
    ctl.reset(task(0.02))
    assert inner.told == 0.05
    h = np.zeros(2)

    def row(t: float, expected: list[float], fresh: bool) -> None:
        u, info = ctl.step(h, t)
        np.testing.assert_array_equal(u, expected)
        np.testing.assert_array_equal(info.u_pred[0], expected)
        assert info.t == t and info.dt == 0.05
        if fresh:
            assert info.fallback == "none" and info.solve_time == 0.5
        else:
            assert info.fallback is Following.FOLLOWING and info.solve_time == 0.0

    row(0.0, [0.0, 0, 0], fresh=True)
    row(0.05, [0.0, 0, 0], fresh=False)  # sends the request of 0.05 s
    release.set()
    assert ctl.answered(10.0)
    release.clear()  # the next request (of 0.06 s) is held
    row(0.06, [0.0, 0, 0], fresh=False)  # acts at 0.08 s, before the new plan's start
    row(0.09, [0.05, 0, 0], fresh=True)  # acts at 0.11 s
    row(0.3, [0.05, 2, 0], fresh=False)
    row(0.6, [0.05, 4, 0], fresh=False)  # row 5 of 5: the last one held
    release.set()
    assert ctl.answered(10.0)
    row(0.7, [0.06, 4, 0], fresh=True)  # the plan of 0.06 s (start 0.11 s) at 0.72 s
    ctl.close()


def test_a_failing_inner_controller_ends_the_run_in_one_line() -> None:
    release = mp.get_context("fork").Event()
    release.set()
    ctl = Asynchronous(Scripted(release, fail=True))
    with pytest.raises(ValueError, match="step before reset"):
        ctl.step(np.zeros(2), 0.0)
    ctl.reset(task(0.05))
    ctl.step(np.zeros(2), 0.0)
    ctl.step(np.zeros(2), 0.05)
    assert ctl.answered(10.0)
    with pytest.raises(RuntimeError, match="Scripted in its solver process: ArithmeticError: scripted failure"):
        ctl.step(np.zeros(2), 0.1)
    ctl.close()


@pytest.mark.parametrize("name", ["lead", "period"])
def test_settings_refuse_non_positive_times(name: str) -> None:
    with pytest.raises(ValueError, match=f"AsyncSettings.{name} = 0.0"):
        replace(AsyncSettings(), **{name: 0.0})


def test_the_switching_nmpc_answers_through_its_worker_as_it_does_here(params) -> None:
    """The worker's answers are the switching NMPC's own: the same controller stepped in this
    process on the same requests (its first state at 0 s, the next at 0.05 s, told the same lead)
    gives the same input and plan to 1e-9 (N, N m): the same compiled code on the same numbers, whose
    last bits still differ between processes (measured: 2e-14 N)."""
    from controller.asynchronous import AsyncSwitchingController
    from controller.switching import SwitchingController
    from validation.closed_loop import task_of
    from validation.scenarios import get as scenario
    from validation.setup import build_plant

    sc = scenario("wall-headon")
    _, scene, _, _ = build_plant(sc, "", 0)
    ctl = AsyncSwitchingController()
    ctl.reset(task_of(sc, params, scene, 0.05))
    here = SwitchingController()
    here.reset(task_of(sc, params, scene, 0.05))
    h0 = task_of(sc, params, scene).h0
    h1 = h0 + 1e-3 * np.arange(len(h0)) / len(h0)
    u, info = ctl.step(h0, 0.0)
    u_here, info_here = here.step(h0, 0.0)
    np.testing.assert_allclose(u, u_here, rtol=0, atol=1e-9)
    ctl.step(h1, 0.05)  # the request of 0.05 s
    assert ctl.answered(60.0)
    u, info = ctl.step(h1, 0.1)  # acts at 0.15 s: the new plan's row 1 (start 0.05 + 0.05, rows of 0.1 s)
    u_here, info_here = here.step(h1, 0.05)
    np.testing.assert_allclose(info.u_pred, info_here.u_pred[int(np.floor((0.15 - 0.1) / info_here.dt + 1e-9)):],
                               rtol=0, atol=1e-9)
    np.testing.assert_array_equal(u, info.u_pred[0])
    assert info.mode == info_here.mode
    ctl.close()
