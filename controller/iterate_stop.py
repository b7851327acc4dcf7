"""Stop IPOPT at an iterate that already answers the question (CasADi's `iteration_callback`).

The certificate's minimum-violation problem (controller.feasibility) asks one thing: is F, Mode I's
feasible set, non-empty? Its first iterate whose inputs, re-simulated, are a point of F answers it;
the rest of IPOPT's run only drives the slacks of inactive constraints to zero with the barrier and
optimizes the 1e-6 tracking regularization, and on hard problems it could walk away from such a
point and end at its iteration cap with slacks of metres.
"""

from __future__ import annotations

from collections.abc import Callable

import casadi as ca
import numpy as np


class IterateStop(ca.Callback):
    """IPOPT's per-iteration callback: stops the solve (IPOPT's User_Requested_Stop) as soon as
    `accept(x, g)` holds for the iterate's primal vector x and constraint values g; `fired` says
    whether the last solve was stopped so (the solver then returns that iterate)."""

    def __init__(self, n_x: int, n_g: int, accept: Callable[[np.ndarray, np.ndarray], bool]):
        ca.Callback.__init__(self)
        self.n_x, self.n_g, self.accept, self.fired = n_x, n_g, accept, False
        self.construct("iterate_stop", {})

    def get_n_in(self) -> int:
        return ca.nlpsol_n_out()

    def get_n_out(self) -> int:
        return 1

    def get_name_in(self, i: int) -> str:
        return ca.nlpsol_out(i)

    def get_name_out(self, i: int) -> str:
        return "stop"

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        name = ca.nlpsol_out(i)
        if name == "f":
            return ca.Sparsity.scalar()
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self.n_x)
        if name in ("g", "lam_g"):
            return ca.Sparsity.dense(self.n_g)
        return ca.Sparsity(0, 0)

    def eval(self, arg: list) -> list[int]:
        if not self.fired:
            self.fired = bool(self.accept(np.asarray(arg[0]).ravel(), np.asarray(arg[2]).ravel()))
        return [1 if self.fired else 0]
