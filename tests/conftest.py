"""Shared fixtures: the default vehicle and scene, hull-only variants, open water."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import pytest

from controller.mode3 import ModeIIIOCP, ModeIIISettings
from controller.model import UVMSModel
from controller.rollouts import ReachPosture
from uvms import load_params, load_scene
from uvms.params import UVMSParams
from uvms.scene import Scene
from validation.closed_loop import initial_state
from validation.scenarios import wall_approach


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


@pytest.fixture(scope="session")
def contact_case(params, scene):
    """Thrusters dead, hull 0.35 m from the wall approaching at 0.3 m/s, tip on the wall."""
    model = UVMSModel(params, scene.water)
    ocp = ModeIIIOCP(model, scene.planes, 0, ModeIIISettings())
    lo, hi = params.input_bounds()
    lo[:8] = hi[:8] = 0.0
    ocp.limit_inputs(lo, hi)
    h, _ = initial_state(params, wall_approach(0.35, 0.3))
    n = params.n_joints
    h[6:6 + n] = ReachPosture(model, scene.planes[0])(h)
    h[6:6 + n] = ocp.onto_plane(h)
    return model, ocp, h
