"""Controllers that take their process down, for the campaign tests: each speaks controller.protocol
and fails the way a native library or the machine can (a segfault, SIGKILL as the OOM killer sends
it, a step that never returns)."""

from __future__ import annotations

import ctypes
import os
import signal
import time
from abc import ABC, abstractmethod

import numpy as np

from controller.protocol import StepInfo, Task


class _Zero(ABC):
    """Zero input until t = 0.1 s, then `fail`."""

    def reset(self, task: Task) -> None:
        self.n = task.params.n_inputs

    def step(self, h: np.ndarray, t: float) -> tuple[np.ndarray, StepInfo]:
        if t >= 0.1:
            self.fail()
        return np.zeros(self.n), StepInfo(t=t, dt=0.05, mode="zero")

    @abstractmethod
    def fail(self) -> None: ...


class Segfaulting(_Zero):
    """Reads address 0 at t = 0.1 s: SIGSEGV."""

    def fail(self) -> None:
        ctypes.string_at(0)


class Killed(_Zero):
    """Sends itself SIGKILL at t = 0.1 s (what the OOM killer does)."""

    def fail(self) -> None:
        os.kill(os.getpid(), signal.SIGKILL)


class Hanging(_Zero):
    """Never returns from its step at t = 0.1 s."""

    def fail(self) -> None:
        while True:
            time.sleep(60)
