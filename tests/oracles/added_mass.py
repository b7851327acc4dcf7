"""Pinocchio with the parameter file's added mass and buoyancy: an oracle of the UVMS at rest.

Paper coordinates as in tests/oracles/rigid_body.py (Pinocchio's free-flyer velocity is nu). Added
mass: every body's diagonal tensor a_b [kg x3, kg m^2 x3] in its own frame about its hydrodynamic
centre (the hull: `hull.added_mass` about the hull origin; a link: `Link.added_mass(rho)` about
its centre, (length / 2, 0, 0) in its frame), entered as sum_b J_b^T diag(a_b) J_b with J_b
Pinocchio's LOCAL Jacobian of a frame at that centre (body-frame velocity of the centre and the
body's angular velocity per unit nu). Buoyancy: rho V g upwards at each centre of buoyancy,
through the LOCAL_WORLD_ALIGNED Jacobian of a frame there. The velocity terms of the added mass
are not represented, so `bias_at_rest` takes states with nu = 0 only.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from oracles.rigid_body import GRAVITY, PinocchioOracle, split_state
from uvms.params import UVMSParams


class PinocchioAddedMassOracle(PinocchioOracle):
    """M(q) with added mass and the at-rest bias (gravity minus buoyancy) by Pinocchio."""

    def __init__(self, params: UVMSParams, rho: float, gravity: float = GRAVITY) -> None:
        """params: the vehicle; rho: water density [kg/m^3]; gravity: g [m/s^2] along world -z."""
        super().__init__(params, gravity)
        self.rho, self.gravity = rho, gravity
        m = self.model
        root = m.frames[m.getFrameId("hull")].parentJoint
        self._centres = [(m.addFrame(pin.Frame("hull_centre", root, pin.SE3.Identity(), pin.FrameType.OP_FRAME)),
                          np.asarray(params.hull.added_mass, float))]
        self._cobs = [(m.addFrame(pin.Frame("hull_cob", root, pin.SE3(np.eye(3), np.asarray(params.hull.cob, float)),
                                            pin.FrameType.OP_FRAME)), params.hull.volume)]
        for lk in params.arm.links:
            jid = m.getJointId(f"{lk.name}_joint")
            centre = pin.SE3(np.eye(3), np.array([lk.length / 2, 0.0, 0.0]))
            self._centres.append((m.addFrame(pin.Frame(f"{lk.name}_centre", jid, centre, pin.FrameType.OP_FRAME)),
                                  lk.added_mass(rho)))
            cob = pin.SE3(np.eye(3), np.asarray(lk.cob, float))
            self._cobs.append((m.addFrame(pin.Frame(f"{lk.name}_cob", jid, cob, pin.FrameType.OP_FRAME)), lk.volume))
        self.data = m.createData()

    def _jacobian(self, h: np.ndarray, frame: int, ref: pin.ReferenceFrame) -> np.ndarray:
        return pin.getFrameJacobian(self.model, self.data, frame, ref)

    def added_mass_matrix(self, h: np.ndarray) -> np.ndarray:
        """A(q) (n, n) [kg, kg m, kg m^2] = sum_b J_b^T diag(a_b) J_b (LOCAL Jacobians)."""
        pin.computeJointJacobians(self.model, self.data, self.configuration(h))
        pin.updateFramePlacements(self.model, self.data)
        A = np.zeros((self.model.nv, self.model.nv))
        for frame, a in self._centres:
            J = self._jacobian(h, frame, pin.ReferenceFrame.LOCAL)
            A += J.T @ (a[:, None] * J)
        return A

    def mass_matrix(self, h: np.ndarray) -> np.ndarray:
        """M(q) (n, n): the rigid CRBA matrix (armature included) plus A(q)."""
        return super().mass_matrix(h) + self.added_mass_matrix(h)

    def bias_at_rest(self, h: np.ndarray) -> np.ndarray:
        """b(q, 0) (n,) [N, N m]: RNEA's gravity minus the generalized buoyancy force (nu = 0 only)."""
        if np.any(split_state(h, self.n_joints)[3] != 0):
            raise ValueError("bias_at_rest takes states at rest (nu = 0); allowed: nu = 0")
        b = super().bias(h)
        pin.computeJointJacobians(self.model, self.data, self.configuration(h))
        pin.updateFramePlacements(self.model, self.data)
        up = np.array([0.0, 0.0, self.rho * self.gravity])
        for frame, volume in self._cobs:
            J = self._jacobian(h, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            b -= J[:3].T @ (volume * up)
        return b
