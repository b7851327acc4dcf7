"""Shared fixtures: the default vehicle and scene, hull-only variants, open water."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import pytest

from uvms import load_params, load_scene
from uvms.params import UVMSParams
from uvms.scene import Scene


@pytest.fixture(scope="session")
def params() -> UVMSParams:
    return load_params()


@pytest.fixture(scope="session")
def scene() -> Scene:
    return load_scene()


@pytest.fixture(scope="session")
def open_water(scene: Scene) -> Scene:
    """The default water with no obstacles."""
    return scene.with_planes(())


@pytest.fixture(scope="session")
def hull_only() -> UVMSParams:
    """The bare literature hull (no arm, no trim): slightly heavy, CoM at the origin, CoB 1 cm above."""
    return load_params(trim=False).without_arm()
