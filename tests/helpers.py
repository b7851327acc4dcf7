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
