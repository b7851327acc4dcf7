"""A controller whose solves run in another process, so that its steps never wait for them.

`Asynchronous` wraps any controller of controller.protocol (the inner controller). At `reset` the
inner controller is reset in this process, then a worker process is forked that owns it from then
on (forked, so that the task's reference, a closure, and the compiled solvers need not be pickled
or loaded again). Each `step`:

1. takes the worker's answer if one has arrived: the inner controller's input and its plan
   (StepInfo.u_pred, rows of StepInfo.dt each) for a state measured at t_r;
2. if the worker is idle, sends it the measured state and t (a request);
3. returns, without waiting, the row of the newest plan that acts at t + L (L: the task's latency,
   the delay after which the closed loop applies this step's answer), its last row once the plan
   runs out. Until its first answer the wrapper waits: there is no plan yet.

The inner controller is told the latency `lead` = max(settings.lead, L) (Task.latency), so that
each plan starts from the state it predicts for t_r + lead (controller.switching: the inner
controller's own first step starts at t_r). An answer that comes back after its plan's start is
joined where the clock is (its first rows are skipped); one that comes back before is held until
its start, the previous plan acting meanwhile. With one worker, requests are made only between
answers: the state of a request is the latest measured one when the worker became free.

A step that follows a plan already applied reports that plan's StepInfo with t and dt its own,
u_pred the plan's rows from t + L on, `fallback` FOLLOWING, no solve (solve_time, ocp_time and
iterations 0, no certificate, switch, prediction or impact force); the step that takes a fresh
answer reports the inner controller's StepInfo the same way, with its solve's timing.

Not deterministic: which state each request carries depends on how long the solves take. The
closed loop (validation.closed_loop) paces the plant to real time whenever a latency is declared,
so that the worker's wall-clock time is the plant's time.

A worker that dies or raises ends the run with a one-line error naming the inner controller.
"""

from __future__ import annotations

import multiprocessing as mp
import weakref
from dataclasses import dataclass, field, replace
from enum import Enum
from multiprocessing.connection import Connection

import numpy as np

from controller.protocol import Controller, StepInfo, Task
from controller.switching import SwitchingController, SwitchingSettings


class Following(Enum):
    """StepInfo.fallback of a step that applies an earlier answer's plan."""

    FOLLOWING = "following an earlier answer's plan (the worker is solving)"


@dataclass(frozen=True)
class AsyncSettings:
    """The wrapper's settings (units beside each)."""

    lead: float = 0.05  # s: the inner controller plans from the state this long after its request (at least L)
    period: float = 0.05  # s: how long each step's input is held (StepInfo.dt; at least L): how often answers are taken

    def __post_init__(self) -> None:
        for name in ("lead", "period"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"AsyncSettings.{name} = {value}; allowed: a finite number of seconds > 0")


@dataclass(frozen=True)
class _Plan:
    """An answer: the inner controller's StepInfo, and when its first row starts acting [s]."""

    info: StepInfo
    u: np.ndarray  # (K, nu) rows, each for info.dt
    start: float

    def rows_from(self, tau: float) -> np.ndarray:
        """The rows from the one acting at tau [s] on (the last row once the plan has run out)."""
        k = int(np.floor((tau - self.start) / self.info.dt + 1e-9))
        return self.u[min(max(k, 0), len(self.u) - 1):]


def _serve(inner: Controller, conn: Connection) -> None:
    """The worker's loop: (h, t) in, (u, info, None) or (None, None, error text) out; None ends it."""
    while True:
        request = conn.recv()
        if request is None:
            return
        try:
            u, info = inner.step(*request)
            conn.send((np.asarray(u, float), info, None))
        except Exception as error:  # sent to the parent, which raises it in one line
            conn.send((None, None, f"{type(error).__name__}: {error}"))


def _stop(process: mp.process.BaseProcess, conn: Connection) -> None:
    try:
        conn.send(None)
    except (OSError, ValueError):
        pass
    process.join(timeout=0.2)
    if process.is_alive():
        process.kill()
        process.join()
    conn.close()


class Asynchronous:
    """The inner controller's solves in a forked worker; steps that never wait (module docstring)."""

    def __init__(self, inner: Controller, settings: AsyncSettings = AsyncSettings()):
        self.inner, self.settings = inner, settings
        self._conn: Connection | None = None
        self._finalizer: weakref.finalize | None = None
        self._plan: _Plan | None = None
        self._pending: _Plan | None = None
        self._busy_since: float | None = None
        self._latency = self._lead = 0.0
        self._name = f"{type(inner).__module__}:{type(inner).__qualname__}"

    def reset(self, task: Task) -> None:
        self.close()
        self._latency = float(task.latency)
        self._lead = max(self.settings.lead, self._latency)
        self.inner.reset(replace(task, latency=self._lead))
        ours, theirs = mp.get_context("fork").Pipe()
        process = mp.get_context("fork").Process(target=_serve, args=(self.inner, theirs), daemon=True,
                                                 name="uvms-async-solver")
        process.start()
        theirs.close()
        self._conn = ours
        self._finalizer = weakref.finalize(self, _stop, process, ours)
        self._plan = self._pending = None
        self._busy_since = None

    def close(self) -> None:
        """Stop the worker (also done when the wrapper is garbage-collected)."""
        if self._finalizer is not None:
            self._finalizer()
        self._finalizer, self._conn = None, None

    def answered(self, timeout: float = 0.0) -> bool:
        """Whether the worker's answer is waiting, after waiting up to `timeout` [s] for it."""
        return self._conn is not None and self._busy_since is not None and self._conn.poll(timeout)

    def _answer(self, wait: bool) -> _Plan | None:
        """The worker's answer, if there is one (waiting for it with `wait`)."""
        assert self._conn is not None and self._busy_since is not None
        if not wait and not self._conn.poll():
            return None
        try:
            u, info, error = self._conn.recv()
        except EOFError:
            raise RuntimeError(f"the solver process of {self._name} died; allowed: an inner controller whose step "
                               "returns") from None
        if error is not None:
            raise RuntimeError(f"{self._name} in its solver process: {error}")
        first = self._plan is None and self._pending is None
        start = self._busy_since + (0.0 if first else self._lead)
        rows = np.asarray(info.u_pred, float) if info.u_pred is not None else np.asarray(u, float)[None]
        self._busy_since = None
        return _Plan(info, rows, start)

    def _request(self, h: np.ndarray, t: float) -> None:
        assert self._conn is not None
        self._conn.send((np.asarray(h, float).copy(), float(t)))
        self._busy_since = float(t)

    def step(self, h: np.ndarray, t: float) -> tuple[np.ndarray, StepInfo]:
        if self._conn is None:
            raise ValueError("step before reset; allowed: reset(task) first")
        first = self._plan is None and self._pending is None and self._busy_since is None
        if first:
            self._request(h, t)
        if self._busy_since is not None:
            answer = self._answer(wait=self._plan is None and self._pending is None)
            if answer is not None:
                self._pending = answer
        tau = t + self._latency
        adopted = self._pending is not None and (self._plan is None or tau >= self._pending.start - 1e-9)
        if adopted:
            self._plan, self._pending = self._pending, None
        if self._busy_since is None and not first:
            self._request(h, t)
        assert self._plan is not None
        rows, info = self._plan.rows_from(tau), self._plan.info
        if not adopted:
            info = replace(info, fallback=Following.FOLLOWING, solve_time=0.0, ocp_time=0.0, iterations=0,
                           certificate=None, switch=None, h_pred=None, contact_force=None, impact_force=None)
        return rows[0].copy(), replace(info, t=t, dt=max(self.settings.period, self._latency), u_pred=rows.copy())


@dataclass(frozen=True)
class AsyncSwitchingSettings:
    """The switching NMPC's settings (`switching.`) and the wrapper's (`asynchronous.`)."""

    switching: SwitchingSettings = field(default_factory=SwitchingSettings)
    asynchronous: AsyncSettings = field(default_factory=AsyncSettings)


class AsyncSwitchingController(Asynchronous):
    """The switching NMPC (controller.switching.SwitchingController) with its solves in a worker."""

    settings_type = AsyncSwitchingSettings

    def __init__(self, settings: AsyncSwitchingSettings = AsyncSwitchingSettings()):
        super().__init__(SwitchingController(settings.switching), settings.asynchronous)


__all__ = ["AsyncSettings", "AsyncSwitchingController", "AsyncSwitchingSettings", "Asynchronous", "Following"]
