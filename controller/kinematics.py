"""Kinematics of the UVMS in CasADi (paper eq. IN2EE and Jv), from the parameter file's conventions.

Frames: the hull (body) frame B; link k's frame rotates with joint k and is parallel to B at q = 0.
Joint k sits at `hull.arm_mount` (k = 0) or at (length_{k-1}, 0, 0) in link k-1's frame. All
quantities here are expressed in B unless their name ends in `_w` (world).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from uvms.params import UVMSParams


def skew(r: ca.SX) -> ca.SX:
    """S(r) with S(r) x = r x x."""
    return ca.vertcat(ca.horzcat(0, -r[2], r[1]), ca.horzcat(r[2], 0, -r[0]), ca.horzcat(-r[1], r[0], 0))


def rot_axis(axis: np.ndarray, q: ca.SX) -> ca.SX:
    """Rotation by angle q [rad] about a unit axis (Rodrigues)."""
    K = skew(ca.DM(axis))
    return ca.DM.eye(3) + ca.sin(q) * K + (1 - ca.cos(q)) * (K @ K)


def euler_zyx(phi: ca.SX, theta: ca.SX, psi: ca.SX) -> ca.SX:
    """R = Rz(psi) Ry(theta) Rx(phi): body to world."""
    cf, sf, ct, st, cp, sp = ca.cos(phi), ca.sin(phi), ca.cos(theta), ca.sin(theta), ca.cos(psi), ca.sin(psi)
    return ca.vertcat(
        ca.horzcat(cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf),
        ca.horzcat(sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf),
        ca.horzcat(-st, ct * sf, ct * cf),
    )


COS_THETA_GUARD = 1e-3  # |cos(theta)| is held at least this in the Euler-rate map (theta -> +-90 deg)


def euler_rates(euler: ca.SX, omega: ca.SX) -> ca.SX:
    """ZYX Euler angle rates from the body-frame angular velocity. Singular at theta = +-90 deg:
    there |cos(theta)| is held at COS_THETA_GUARD (rates stay finite but wrong within 0.06 deg)."""
    phi, theta = euler[0], euler[1]
    c = ca.cos(theta)
    c = ca.if_else(c >= 0, ca.fmax(c, COS_THETA_GUARD), ca.fmin(c, -COS_THETA_GUARD))
    t = ca.sin(theta) / c
    cf, sf = ca.cos(phi), ca.sin(phi)
    return ca.vertcat(omega[0] + sf * t * omega[1] + cf * t * omega[2],
                      cf * omega[1] - sf * omega[2],
                      (sf * omega[1] + cf * omega[2]) / c)


@dataclass(frozen=True)
class LinkFrames:
    """Symbolic link frames in B as functions of q_m: rotations C[k] (link k -> B), joint origins
    o[k] and joint axes z[k] (in B)."""

    C: list[ca.SX]
    o: list[ca.SX]
    z: list[ca.SX]

    def point(self, k: int, r: np.ndarray) -> ca.SX:
        """Position in B of a point fixed at r in link k's frame."""
        return self.o[k] + self.C[k] @ ca.DM(r)


def link_frames(params: UVMSParams, qm: ca.SX) -> LinkFrames:
    C, o, z = [], [], []
    R, origin = ca.SX.eye(3), ca.SX(ca.DM(params.hull.arm_mount))
    for k, lk in enumerate(params.arm.links):
        if k > 0:
            origin = origin + R @ ca.DM([params.arm.links[k - 1].length, 0.0, 0.0])
        z.append(R @ ca.DM(lk.joint_axis))
        R = R @ rot_axis(lk.joint_axis, qm[k])
        C.append(R)
        o.append(origin)
    return LinkFrames(C, o, z)
