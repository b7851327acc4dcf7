"""The end-effector tip's impact on a plane: the peak normal force of the first instant of contact.

The contact is soft (the parameter file's arm: `contact_time_constant` tau, critically damped;
`contact_impedance` d_max; `contact_weight` w, the tip link's inverse inertia that the plant's
contact uses to regularize it; uvms_mj.build sets the first two on every obstacle). At first touch
the contact asks the tip's normal speed v_n to decay at the rate 2 / (d_max tau), and the force that
does it is that rate times v_n over the inertia the contact sees, 1 / m_eff plus the regularization
(1 - d_max) / d_max * w in series:

    F = 2 v_n / (d_max tau) / (1 / m_eff + (1 - d_max) / d_max * w)

m_eff is the UVMS's inertia at the tip along the plane's normal with the tip held in the plane's
tangent directions too (friction sticks during the impact's milliseconds): the normal entry of
(C M^-1 C^T)^-1, C the normal and two tangent rows of the tip's world-frame linear Jacobian and M
the mass matrix with added mass. The joints are torque-driven, so free. This is an upper bound:
a tip that slides, or a contact still short of d_max, takes less (experiments/impact_law).
"""

from __future__ import annotations

import numpy as np

from controller.model import UVMSModel
from uvms.scene import Plane


def approach_speed(model: UVMSModel, h: np.ndarray, plane: Plane) -> float:
    """The tip's speed towards the plane [m/s] (positive: approaching)."""
    J = np.asarray(model.jacobian_ee(h))[:3, :]
    return float(-plane.normal @ J @ h[model.n_speeds:])


def effective_mass(model: UVMSModel, h: np.ndarray, normal: np.ndarray) -> float:
    """The inertia [kg] the tip presents along the unit `normal` (world) at state h, its tangential
    motion held (sticking friction), the joints free."""
    n = np.asarray(normal, float)
    t1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    C = np.vstack([n, t1, np.cross(n, t1)]) @ np.asarray(model.jacobian_ee(h))[:3, :]
    M, _ = model.mass_and_bias(h)
    return float(np.linalg.inv(C @ np.linalg.solve(M, C.T))[0, 0])


def stiffness(model: UVMSModel, h: np.ndarray, plane: Plane) -> float:
    """The peak normal force per unit approach speed [N s/m] of the tip meeting the plane in h's
    posture (the module's law)."""
    arm = model.params.arm
    d, tau = arm.contact_impedance, arm.contact_time_constant
    return 2.0 / (d * tau) / (1.0 / effective_mass(model, h, plane.normal) + (1.0 - d) / d * arm.contact_weight)


def peak_force(model: UVMSModel, h: np.ndarray, plane: Plane) -> float:
    """The predicted peak normal force [N] of the tip meeting the plane from state h (0 when the tip
    moves away)."""
    return stiffness(model, h, plane) * max(approach_speed(model, h, plane), 0.0)
