"""The certificate's minimum-violation problem on a second thread, so that Mode I's steps stay
short (opt-in: SwitchingSettings.background_certificate; not in the paper).

The synchronous certificate (controller.feasibility) blocks the step for 0.5-2.5 s whenever its
screens fail, and the plant does not wait in reality: with that delay the previous input acts
meanwhile (validation.closed_loop's `--latency measured`). Here the step only runs the screens;
when they fail it starts the minimum-violation problem from the measured state on a worker thread
(one at a time; IPOPT runs without Python's global lock, on the second core) and goes on with
Mode I's real-time plan (Verdict.PENDING). A later step takes the finished verdict: it judges the
state the job started from, `Certificate.age` seconds older than the step's. A screen that
certifies F at a later step makes a running job's verdict stale, and it is dropped; so is one that
finishes after the controller left Mode I. With a `wait` (SwitchingSettings.certificate_wait) the
step that starts a job waits that long for it: a job done by then gives its verdict at once, on the
step's own state, as the synchronous certificate does; a longer one goes on in the background.
"""

from __future__ import annotations

import time
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as futures_wait
from dataclasses import replace

import numpy as np

from controller.feasibility import Certificate, FeasibilityTest


class BackgroundCertificate:
    """One worker thread that solves `test`'s minimum-violation problem. Only the worker calls
    the problem's solver; the caller's thread builds the start (the problem's clearance function)."""

    def __init__(self, test: FeasibilityTest):
        self.test = test
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="certificate")
        self._job: Future | None = None
        self._started = 0.0  # s, the state time of the job
        self._stale = False

    @property
    def busy(self) -> bool:
        return self._job is not None and not self._job.done()

    def submit(self, h0: np.ndarray, h_ref: np.ndarray, current: np.ndarray, screened: Certificate,
               t: float, plan: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Start the problem for state h0 at time t [s] as the synchronous certificate does: from
        `plan` (Mode I's fresh plan: states, inputs) when given and the test starts from it, else
        from the braking rollout of `screened` (the screens' certificate for h0). Refused while a
        job runs (one at a time)."""
        if self.busy:
            raise RuntimeError("BackgroundCertificate.submit: a job is running; allowed: one at a time")
        self._cancel(False)
        start = plan if plan is not None and self.test.plan_start else (screened.rollout, screened.rollout_inputs)
        hs, us = start[0].copy(), start[1].copy()
        guess = self.test.problem.guess_from_rollout(hs, us)
        args = (np.array(h0, float), np.array(h_ref, float), np.array(current, float), guess,
                screened.rollout_clearance, hs, us)
        self._job, self._started, self._stale = self._pool.submit(self._solve, *args), t, False

    def _solve(self, h0: np.ndarray, h_ref: np.ndarray, current: np.ndarray, guess: np.ndarray, clearance: float,
               hs: np.ndarray, us: np.ndarray) -> Certificate:
        t0 = time.perf_counter()
        sol = self.test.problem.solve(h0, h_ref, current, guess=guess)
        return self.test.judge(sol, clearance, time.perf_counter() - t0, hs, us)

    def take(self, t: float, wait: float = 0.0) -> Certificate | None:
        """The finished job's certificate, once, aged to time t [s], after waiting up to `wait` [s]
        of wall clock for a running job; None while it runs, when there is none, or when it went
        stale."""
        if self._job is not None and wait > 0:
            futures_wait([self._job], timeout=wait)
        if self._job is None or not self._job.done():
            return None
        job, self._job = self._job, None
        cert = job.result()
        return None if self._stale else replace(cert, age=t - self._started)

    def _cancel(self, cancelled: bool) -> None:
        """Set the problem's stop to end (True) or to let run (False) the worker's IPOPT."""
        if self.test.problem.stop is not None:
            self.test.problem.stop.cancelled = cancelled

    def discard(self) -> None:
        """Drop the verdict of the running or finished job (the state it judges no longer matters);
        a running IPOPT stops at its next iteration (with Stop.NONE, which has no callback, it runs
        to its end)."""
        self._stale = True
        self._cancel(True)
        if self._job is not None and self._job.done():
            self._job = None
