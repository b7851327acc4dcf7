"""Mode entries solved ahead, in a helper process, while the mode before them runs.

A mode's first solve starts cold and in strict real time at 50 ms it is often late: Mode II's
deploy (the switching step, 64 ms median) and Mode III's first solve (over the whole horizon 100 ms
median, 43 IPOPT iterations; over two intervals, `mode3_entry_intervals`, late in about 4 of 10
episodes); later solves start from the shifted plan and its multipliers. `EntryHelper` forks a
process that owns a copy of the switching NMPC (forked, so its compiled solvers are not loaded
again) and solves the entries it is sent, as the entry step itself would:

- `DeployEntry`: Mode II from its deploy guess at the state a Mode I plan reaches at its next node
  (submitted by each Mode I step whose braking rollout fails), for a switch in the next step;
- `ContactEntry`: Mode III from Algorithm 2's guess at the state a Mode II plan predicts at
  contact (its last node), with the input it ends with (submitted by each Mode II step);
- `ContactStep`: Mode III's next step from the state its plan reaches at the next node, warm from
  that plan shifted and its multipliers (submitted by each Mode III step), for the next step's
  solve from the measured state to start from: on 266 recorded Mode III problems 7 IPOPT iterations
  at the median and 20 solves of 20 or more, against 11 and 61 from the shifted plan.

Nothing waits: `submit` sends at once and the helper, when free, solves the newest request it
has (older ones of the same kind dropped); `take` returns the newest answer of a kind that has
arrived, for the entry's solve to start from (its states after the first node, inputs,
multipliers). The helper starts each deploy from its previous deploy answer (warm), so that while
Mode I's braking rollout keeps failing its answers keep up with Mode I's steps. A contact answer
outlives the Mode II episode that asked for it (Mode II often starts afresh a step or two before
the hand-over, sooner than a solve comes back); a deploy answer serves only the step after the one
that asked.

Not deterministic (which request each answer answers depends on how long the solves take), so
the switching controller starts it only under a latency in a loop on the wall clock (strict real
time, a measured delay: Task.wall_clock), where the loop's timing already decides what is late.
A helper that dies or raises only stops answering.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import weakref
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from controller.mode2 import ModeIISolution
from controller.mode3 import ModeIIIOCP, ModeIIISolution


@dataclass(frozen=True)
class ContactEntry:
    """A Mode III entry to solve ahead: the contact plane, the horizon, the state at contact, the
    input held into it, the model's water input and the input bounds of the moment."""

    plane: int
    horizon: int
    h: np.ndarray  # (ns,)
    u: np.ndarray  # (nu,)
    current: np.ndarray  # (WATER,)
    lo: np.ndarray  # (nu,)
    hi: np.ndarray  # (nu,)

    def solve(self, nmpc: Any) -> ModeIIISolution | None:
        key = (self.plane, self.horizon)
        ocp: ModeIIIOCP = nmpc._mode3[key] if key in nmpc._mode3 else nmpc.ocp3(self.plane)
        if ocp.settings.horizon != self.horizon:
            return None
        ocp.limit_inputs(self.lo, self.hi)
        held = np.repeat(self.u[None], self.horizon, 0)
        sol = ocp.solve(self.h, ocp.contact_guess(self.h, held, None, self.current), self.current)
        return sol if sol.status.usable else None


@dataclass(frozen=True)
class DeployEntry:
    """A Mode II entry to solve ahead: the contact plane, Algorithm 1's longest horizon, the state
    and its time [s], the model's water input and the input bounds of the moment."""

    plane: int
    horizon: int
    h: np.ndarray  # (ns,)
    t: float  # s
    current: np.ndarray  # (WATER,)
    lo: np.ndarray  # (nu,)
    hi: np.ndarray  # (nu,)

    def solve(self, nmpc: Any) -> ModeIISolution | None:
        """From the helper's last deploy answer for this plane and horizon and its multipliers (a
        Mode I period or so older: warm, about 15 IPOPT iterations), else, or when that fails, from
        the deploy guess (cold, 30 to 100)."""
        ocp = nmpc.ocp2(self.plane)
        ocp.limit_inputs(self.lo, self.hi)
        last = getattr(nmpc, "_deploy_answer", None)
        sol = None
        if last is not None and last[0] == (self.plane, self.horizon):
            prev = last[1]
            sol = ocp.solve(self.h, (np.vstack([self.h, prev.h[1:]]), prev.u, prev.dt), self.current,
                            (prev.lam_g, prev.lam_x))
        if sol is None or not sol.status.usable:
            sol = ocp.solve(self.h, ocp.deploy_guess(self.h, self.horizon, self.current), self.current)
        nmpc._deploy_answer = ((self.plane, self.horizon), sol) if sol.status.usable else None
        return sol if sol.status.usable else None


@dataclass(frozen=True)
class ContactStep:
    """Mode III's next step to solve ahead: the contact plane, the horizon, which of the controller's
    Mode III plans it continues (a count), that plan's recomputed states (N+1, ns) and solution, the
    model's water input and the input bounds of the moment."""

    plane: int
    horizon: int
    plan_index: int
    h: np.ndarray  # (N+1, ns)
    plan: ModeIIISolution
    current: np.ndarray  # (WATER,)
    lo: np.ndarray  # (nu,)
    hi: np.ndarray  # (nu,)

    def solve(self, nmpc: Any) -> ModeIIISolution | None:
        """From the plan's next node, as a Mode III step there would start: the plan's recomputed
        states, inputs and forces shifted by one interval (the last repeated) and its multipliers."""
        ocp: ModeIIIOCP = nmpc.ocp3(self.plane, self.horizon)
        ocp.limit_inputs(self.lo, self.hi)
        p = self.plan
        guess = ocp.pack(np.vstack([self.h[1:], self.h[-1:]]), np.vstack([p.u[1:], p.u[-1:]]),
                         np.vstack([p.force[1:], p.force[-1:]]))
        sol = ocp.solve(self.h[1], guess, self.current, ocp.shifted_duals(p))
        return sol if sol.status.usable else None


Entry = ContactEntry | DeployEntry | ContactStep


def _serve(nmpc: Any, conn: Connection) -> None:
    """The helper's loop: entries in, (entry, usable solution or None) out, the newest entry first
    and older ones of its kind dropped; None ends it."""
    pending: dict[type, Entry] = {}
    while True:
        while not pending or conn.poll():
            request = conn.recv()
            if request is None:
                return
            pending.pop(type(request), None)
            pending[type(request)] = request
        request = pending.pop(next(reversed(pending)))
        try:
            conn.send((request, request.solve(nmpc)))
        except Exception:  # the helper stops answering this request; the parent never waits for it
            conn.send((request, None))


def _stop(process: mp.process.BaseProcess, conn: Connection) -> None:
    with contextlib.suppress(OSError, ValueError):  # the helper already gone
        conn.send(None)
    process.join(timeout=0.2)
    if process.is_alive():
        process.kill()
        process.join()
    conn.close()


class EntryHelper:
    """A forked process that solves mode entries ahead (module docstring)."""

    def __init__(self, nmpc: Any):
        parent, child = mp.get_context("fork").Pipe()
        process = mp.get_context("fork").Process(target=_serve, args=(nmpc, child), daemon=True)
        process.start()
        child.close()
        self._conn = parent
        self._dead = False
        self._answers: dict[type, tuple[Entry, Any]] = {}
        self._finalizer = weakref.finalize(self, _stop, process, parent)

    def _collect(self) -> None:
        try:
            while not self._dead and self._conn.poll():
                request, sol = self._conn.recv()
                if sol is not None:
                    self._answers[type(request)] = (request, sol)
        except (EOFError, OSError):  # the helper died: nothing more is sent
            self._dead = True

    def submit(self, request: Entry) -> None:
        """Solve this entry next (the helper drops a waiting older one of its kind)."""
        self._collect()
        if not self._dead:
            try:
                self._conn.send(request)
            except (OSError, ValueError):
                self._dead = True

    def take(self, kind: type, plane: int, horizon: int) -> tuple[Entry, Any] | None:
        """The newest answer of this kind for this plane and horizon, with its request (then
        forgotten), or None."""
        self._collect()
        answer = self._answers.pop(kind, None)
        if answer is None or (answer[0].plane, answer[0].horizon) != (plane, horizon):
            return None
        return answer

    def close(self) -> None:
        self._finalizer()
