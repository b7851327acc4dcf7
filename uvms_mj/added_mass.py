"""Added mass as a posture-dependent term of MuJoCo's joint-space inertia (numpy and mujoco only).

MuJoCo's fluid model has no inertial term -M_A dv/dt. The plant adds it to the mass matrix:

    A(q) = sum_b G_b^T diag(a_b) G_b,    G_b = [R_b^T J_p(c_b); R_b^T J_r(b)]    (6 x nv)

with, for every body b, its diagonal added-mass tensor a_b [kg x3, kg m^2 x3] in its own frame about
its hydrodynamic centre c_b, and J_p, J_r MuJoCo's world-frame point and rotational Jacobians
(`mj_jac`), so R_b^T J nu is the body-frame velocity of c_b and the body's angular velocity: the
same tensor, frame and point as the paper's Kane model, following the posture and coupling the
links with the hull. G_b is non-zero only on the dofs of b's ancestors, so A(q) lies inside the
sparsity of MuJoCo's mass matrix (a serial tree). `AddedMass.apply` runs after `mj_fwdPosition`:
it adds A(q) to `data.M`, refactors (`mj_factorM`) and recomputes the constraint projection
(`mj_projectConstraint`), so every later stage (smooth acceleration, the constraint solver and
its noslip pass, the implicitfast integrator) solves with M + A: the added-mass force is exact at
any ratio to the rigid inertia and under contact, without iteration.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass(frozen=True)
class AddedMassTerm:
    """One body's diagonal added-mass tensor in its own frame about `point`."""

    body: str
    point: np.ndarray  # (3,) m, body frame
    tensor: np.ndarray  # (6,) kg x3, kg m^2 x3, body axes (linear, then angular)


class AddedMassSolveWarning(RuntimeWarning):
    """The mass matrix with the added mass could not be factorized (a pivot below mjMINVAL)."""


class AddedMass:
    """A(q) for a compiled model, and its insertion into MuJoCo's mass matrix."""

    def __init__(self, model: mujoco.MjModel, terms: tuple[AddedMassTerm, ...]) -> None:
        self.model = model
        self.terms = tuple(t for t in terms if np.any(np.asarray(t.tensor) != 0))
        self._bodies = np.array([model.body(t.body).id for t in self.terms], dtype=int)
        self._points = np.array([np.asarray(t.point, float) for t in self.terms]).reshape(-1, 3)
        self._weights = np.concatenate([np.asarray(t.tensor, float) for t in self.terms]) if self.terms \
            else np.zeros(0)
        nv = model.nv
        rows = np.zeros(model.nM, dtype=int)  # data.M is CSR: row i at M_rowadr[i], M_rownnz[i] entries
        for i in range(nv):
            rows[model.M_rowadr[i]:model.M_rowadr[i] + model.M_rownnz[i]] = i
        self._rows, self._cols = rows, np.asarray(model.M_colind, dtype=int)
        self._jacp, self._jacr = np.zeros((3, nv)), np.zeros((3, nv))
        self._G = np.zeros((6 * len(self.terms), nv))
        self.failures = 0  # physics steps whose factorization with the added mass failed

    @property
    def active(self) -> bool:
        return bool(self.terms)

    def matrix(self, data: mujoco.MjData) -> np.ndarray:
        """A(q) (nv, nv) [kg, kg m, kg m^2] in MuJoCo's qvel coordinates (needs kinematics)."""
        G = self._G
        for i, (b, p) in enumerate(zip(self._bodies, self._points, strict=True)):
            R = data.xmat[b].reshape(3, 3)
            mujoco.mj_jac(self.model, data, self._jacp, self._jacr, data.xpos[b] + R @ p, b)
            G[6 * i:6 * i + 3] = R.T @ self._jacp
            G[6 * i + 3:6 * i + 6] = R.T @ self._jacr
        return G.T @ (self._weights[:, None] * G)

    def apply(self, data: mujoco.MjData) -> bool:
        """Add A(q) to `data.M` after `mj_fwdPosition`, refactor and re-project the constraints.

        Returns False (and counts a failure and warns) if MuJoCo's factorization met a pivot below
        mjMINVAL (it clamps it and counts mjWARN_INERTIA) or a non-finite one; A(q) is positive
        semi-definite, so this flags a broken model."""
        if not self.terms:
            return True
        A = self.matrix(data)
        data.M[:] += A[self._rows, self._cols]
        singular = data.warning[mujoco.mjtWarning.mjWARN_INERTIA]
        before = singular.number
        mujoco.mj_factorM(self.model, data)  # a pivot below mjMINVAL: clamped, and mjWARN_INERTIA
        if data.nefc:
            mujoco.mj_projectConstraint(self.model, data)
        if singular.number == before and np.all(np.isfinite(data.qLDiagInv)):
            return True
        self.failures += 1
        warnings.warn(f"t = {data.time:.4f} s: the mass matrix with the added mass has a non-positive "
                      "pivot; the step's accelerations are not trustworthy", AddedMassSolveWarning, stacklevel=3)
        return False


__all__ = ["AddedMass", "AddedMassSolveWarning", "AddedMassTerm"]
