"""Helpers for the physics experiments (plain functions, imported by the tests)."""

from __future__ import annotations

import dataclasses

import numpy as np

from uvms.params import UVMSParams


def neutral(p: UVMSParams, rho: float) -> UVMSParams:
    """The same vehicle with its hull volume set for neutral buoyancy of the whole vehicle."""
    arm_net = sum(lk.mass - rho * lk.volume for lk in p.arm.links)
    hull = dataclasses.replace(p.hull, volume=(p.hull.mass + arm_net) / rho)
    return dataclasses.replace(p, hull=hull)


def with_hull(p: UVMSParams, **changes: object) -> UVMSParams:
    return dataclasses.replace(p, hull=dataclasses.replace(p.hull, **changes))


def zero_input(p: UVMSParams) -> np.ndarray:
    return np.zeros(p.n_inputs)


def skew(r: np.ndarray) -> np.ndarray:
    """S(r) with S(r) x = r x x."""
    return np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])


def hull_mass_matrix(p: UVMSParams) -> np.ndarray:
    """Fossen's 6x6 rigid-body plus added mass matrix of the hull about its body origin
    (Fossen 2011, eq. 3.44: M_RB = [[m I, -m S(r_g)], [m S(r_g), I_o]]; M_A diagonal)."""
    h = p.hull
    m, rg = h.mass, h.com
    inertia_o = h.inertia + m * (float(rg @ rg) * np.eye(3) - np.outer(rg, rg))
    M = np.block([[m * np.eye(3), -m * skew(rg)], [m * skew(rg), inertia_o]])
    return M + np.diag(h.added_mass)


def random_states(p: UVMSParams, count: int, seed: int) -> list[np.ndarray]:
    """Random states: position N(0, 1) m, any roll and yaw, pitch within 1.3 rad, joints within range,
    speeds N(0, 1)."""
    rng = np.random.default_rng(seed)
    n, out = p.n_joints, []
    for _ in range(count):
        h = np.zeros(p.n_states)
        h[:3] = rng.normal(size=3)
        h[3:6] = [rng.uniform(-np.pi, np.pi), rng.uniform(-1.3, 1.3), rng.uniform(-np.pi, np.pi)]
        lo, hi = np.array([lk.joint_range for lk in p.arm.links]).T
        h[6:6 + n] = rng.uniform(lo, hi)
        h[6 + n:] = rng.normal(0, 1.0, 6 + n)
        out.append(h)
    return out
