"""Mode III's entry solved ahead, in a helper process, while Mode II runs.

Mode III's first solve starts cold from Algorithm 2's guess and in strict real time at 50 ms it is
always late (131 ms median, 43 IPOPT iterations); later solves start from the shifted plan and its
multipliers. `EntryHelper` forks a process that owns a copy of the switching NMPC (forked, so its
compiled solvers are not loaded again). Each Mode II step submits the state its plan predicts at
contact (the plan's last node) with the input it ends with; the helper solves Mode III's problem
there from Algorithm 2's guess, as Mode III's first step would, and sends the plan back. Nothing
waits: `submit` sends only when the helper is idle (else it keeps the newest request for later),
`take` returns the newest answer that has arrived, for Mode III's first solve to start from (its
states after the first node, inputs, forces and multipliers). An answer outlives the Mode II
episode that asked for it: Mode II often starts afresh a step or two before the hand-over, sooner
than a solve comes back.

Not deterministic (which request each answer answers depends on how long the solves take), so
the switching controller starts it only under a declared latency, where the loop's timing already
decides what is late. A helper that dies or raises only stops answering.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import weakref
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from controller.mode3 import ModeIIIOCP, ModeIIISolution


@dataclass(frozen=True)
class EntryRequest:
    """A Mode III entry to solve ahead: the contact plane, the horizon, the state at contact, the
    input held into it, the model's water input and the input bounds of the moment."""

    plane: int
    horizon: int
    h: np.ndarray  # (ns,)
    u: np.ndarray  # (nu,)
    current: np.ndarray  # (WATER,)
    lo: np.ndarray  # (nu,)
    hi: np.ndarray  # (nu,)


def _serve(nmpc: Any, conn: Connection) -> None:
    """The helper's loop: an EntryRequest in, (request, usable solution or None) out; None ends it."""
    while True:
        request = conn.recv()
        if request is None:
            return
        try:
            key = (request.plane, request.horizon)
            ocp: ModeIIIOCP = nmpc._mode3[key] if key in nmpc._mode3 else nmpc.ocp3(request.plane)
            if ocp.settings.horizon != request.horizon:
                conn.send((request, None))
                continue
            ocp.limit_inputs(request.lo, request.hi)
            held = np.repeat(request.u[None], request.horizon, 0)
            guess = ocp.contact_guess(request.h, held, None, request.current)
            sol = ocp.solve(request.h, guess, request.current)
            conn.send((request, sol if sol.status.usable else None))
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
    """A forked process that solves Mode III's entry ahead (module docstring)."""

    def __init__(self, nmpc: Any):
        parent, child = mp.get_context("fork").Pipe()
        process = mp.get_context("fork").Process(target=_serve, args=(nmpc, child), daemon=True)
        process.start()
        child.close()
        self._conn = parent
        self._busy = False
        self._pending: EntryRequest | None = None
        self._answer: tuple[EntryRequest, ModeIIISolution] | None = None
        self._finalizer = weakref.finalize(self, _stop, process, parent)

    def _collect(self) -> None:
        try:
            while self._conn.poll():
                request, sol = self._conn.recv()
                self._busy = False
                if sol is not None:
                    self._answer = (request, sol)
        except (EOFError, OSError):  # the helper died: it stays busy, so nothing more is sent
            self._busy = True
            return
        if not self._busy and self._pending is not None:
            self._conn.send(self._pending)
            self._busy, self._pending = True, None

    def submit(self, request: EntryRequest) -> None:
        """Solve this entry when the helper is free (the newest request replaces a waiting one)."""
        self._pending = request
        self._collect()

    def take(self, plane: int, horizon: int) -> ModeIIISolution | None:
        """The newest answer for this plane and horizon (then forgotten), or None."""
        self._collect()
        answer, self._answer = self._answer, None
        if answer is None or (answer[0].plane, answer[0].horizon) != (plane, horizon):
            return None
        return answer[1]

    def close(self) -> None:
        self._finalizer()
