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
