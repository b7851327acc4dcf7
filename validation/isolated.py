"""Work in a Python process of its own: a campaign's runs (and a host's compile-ahead) are sent, one at a
time, to a child process (`python -m validation.isolated`) that the calling thread owns; the job
goes pickled to the child's stdin (plain data: scenarios, names, numbers) and the result comes back
as JSON on the child's original stdout (whatever the work prints goes to the child's stderr, kept in
a temporary file).

A job that takes longer than its timeout gets its child killed and is reported as "timeout"; a child
that dies (killed, a segfault in a native library, the OOM killer) has its job reported as "worker
died: ..." with the signal or the exit code and the last line it wrote to stderr. Either way the
next job gets a fresh child, as it does after RUNS_PER_CHILD jobs. A child whose parent dies exits
within a second. Nothing needs `multiprocessing`, so the same call works in a campaign's own threads
and inside a Dask worker (whose processes may not start multiprocessing children).
"""

from __future__ import annotations

import contextlib
import json
import os
import pickle
import select
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from typing import Any

TIMEOUT = "timeout"
DIED = "worker died"
RUNS_PER_CHILD = 25  # a fresh child after this many jobs bounds what a leak in a native library can grow to
_HEADER = struct.Struct("<Q")  # the byte length of the frame that follows
READY = b"ready"  # the child's first frame: its imports are done
STARTUP_S = 300.0  # the longest a child may take to import the testbed (a cold, loaded machine)


@dataclass(frozen=True)
class Outcome:
    """What came back from a child: its result (None when it failed), else the failure's verdict and
    one-line reason, and the job's wall time [s] in the child."""

    result: Any
    verdict: str | None
    reason: str
    wall_s: float


def _signal_name(code: int) -> str:
    try:
        return signal.Signals(-code).name
    except ValueError:
        return f"signal {-code}"


class Child:
    """One child process and the pipes to it; used by one thread at a time."""

    def __init__(self) -> None:
        self.stderr = tempfile.TemporaryFile()
        self.proc = subprocess.Popen([sys.executable, "-m", "validation.isolated"], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self.stderr)
        self.jobs, self.ready = 0, False

    def alive(self) -> bool:
        return self.proc.poll() is None

    def _read(self, n: int, deadline: float | None) -> bytes | None:
        """n bytes from the child, or None at the deadline; b"" when it closed its end (died)."""
        fd, chunks, got = self.proc.stdout.fileno(), [], 0
        while got < n:
            wait = None if deadline is None else deadline - time.monotonic()
            if wait is not None and wait <= 0:
                return None
            ready, _, _ = select.select([fd], [], [], wait)
            if not ready:
                return None
            chunk = os.read(fd, n - got)
            if not chunk:
                return b""
            chunks.append(chunk)
            got += len(chunk)
        return b"".join(chunks)

    def ask(self, kind: str, payload: Any, timeout: float | None) -> Outcome:
        if not self.ready:  # the child's imports are not the job's time
            header = self._read(_HEADER.size, time.monotonic() + STARTUP_S)
            if header is None:
                self.kill()
                return Outcome(None, DIED, f"{DIED}: not started within {STARTUP_S:g} s", 0.0)
            if not header or self._read(_HEADER.unpack(header)[0], None) != READY:
                return Outcome(None, DIED, self._cause(), 0.0)
            self.ready = True
        t0 = time.monotonic()
        self.jobs += 1
        deadline = None if timeout is None else t0 + timeout
        try:
            frame = pickle.dumps((kind, payload))
            self.proc.stdin.write(_HEADER.pack(len(frame)) + frame)
            self.proc.stdin.flush()
            header = self._read(_HEADER.size, deadline)
            body = self._read(_HEADER.unpack(header)[0], deadline) if header else header
        except (BrokenPipeError, ConnectionError):
            body = b""
        wall = time.monotonic() - t0
        if body is None:
            self.kill()
            return Outcome(None, TIMEOUT, f"stopped after {timeout:g} s (the campaign's --timeout)", wall)
        if not body:
            return Outcome(None, DIED, self._cause(), wall)
        return Outcome(json.loads(body), None, "", wall)

    def _cause(self) -> str:
        try:
            code = self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.kill()
            code = self.proc.wait()
        what = f"killed by {_signal_name(code)}" if code < 0 else f"exit code {code}"
        self.stderr.seek(0)
        lines = self.stderr.read()[-4000:].decode(errors="replace").splitlines()
        last = next((line.strip() for line in reversed(lines) if line.strip()), "")
        return f"{DIED}: {what}" + (f" ({last[:200]})" if last else "")

    def kill(self) -> None:
        with contextlib.suppress(OSError):
            self.proc.kill()
        self.proc.wait()

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.proc.stdin.close()  # the child's loop ends at end of input
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.kill()
        self.stderr.close()


_mine = threading.local()  # the calling thread's child
_all: set[Child] = set()
_lock = threading.Lock()


def call(kind: str, payload: Any, timeout: float | None = None) -> Outcome:
    """Run `kind` ("run": validation.campaign.execute on a Job; "build": validation.precompile.build on
    (scenarios, controllers, ctl)) with `payload` in this thread's child, within `timeout` seconds."""
    child: Child | None = getattr(_mine, "child", None)
    if child is None or not child.alive() or child.jobs >= RUNS_PER_CHILD:
        if child is not None:
            _forget(child)
            child.close()
        child = _mine.child = Child()
        with _lock:
            _all.add(child)
    out = child.ask(kind, payload, timeout)
    if out.verdict is not None:  # timed out or died: the next job gets a fresh child
        _forget(child)
        _mine.child = None
        child.close()
    return out


def _forget(child: Child) -> None:
    with _lock:
        _all.discard(child)


def stop_all() -> None:
    """End every child of this process (the campaign is stopping): idle ones at once, busy ones killed."""
    with _lock:
        children = list(_all)
        _all.clear()
    for child in children:
        child.kill()
        child.stderr.close()
    _mine.child = None


def _orphan_watch(parent: int) -> None:
    """Exit when the process that started this one is gone (its campaign was killed)."""
    while os.getppid() == parent:
        time.sleep(0.5)
    os._exit(1)


def _serve() -> None:
    """The child: read (kind, payload) frames from stdin until it closes; answer each on stdout."""
    threading.Thread(target=_orphan_watch, args=(os.getppid(),), daemon=True).start()
    requests, answers = sys.stdin.buffer, os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # whatever the work prints goes to stderr; stdout carries the answers alone
    import validation.campaign
    import validation.closed_loop  # noqa: F401  (the heavy imports, before the first job's clock starts)
    answers.write(_HEADER.pack(len(READY)) + READY)
    answers.flush()
    while header := requests.read(_HEADER.size):
        kind, payload = pickle.loads(requests.read(_HEADER.unpack(header)[0]))
        if kind == "run":
            from validation.campaign import execute
            result = execute(payload)
        elif kind == "build":
            from validation.precompile import build
            scenarios, controllers, ctl = payload
            result = build(scenarios, controllers, ctl, quiet=True)
        else:
            raise SystemExit(f"validation.isolated: unknown kind {kind!r}; allowed: run, build")
        body = json.dumps(result).encode()
        answers.write(_HEADER.pack(len(body)) + body)
        answers.flush()


if __name__ == "__main__":
    _serve()
