"""From a scenario to the closed loop's inputs: the scene, the start state, the task's reference, the
current profile and the plant with its faults (the mechanisms; the scenario files hold the settings)."""

from __future__ import annotations

import numpy as np

from uvms import load_params, load_scene
from uvms.params import UVMSParams
from uvms.scene import Current, Scene
from uvms_mj.plant import Plant, PlantSettings, ThrusterFault
from validation import mismatch as mismatches
from validation.scenarios import Scenario


def wall_x() -> float:
    """x [m] of the default scene's wall (read from the scene file: numbers live there once)."""
    return float(next(p for p in load_scene().planes if p.name == "wall").point[0])


def initial_state(params, sc: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """The start state and the task's reference state."""
    n = params.n_joints
    if sc.posture not in ("stowed", "home"):
        raise ValueError(f"posture {sc.posture!r}; allowed: stowed, home")
    front, wall = params.hull.superellipsoid.semi_axes[0], wall_x()
    h = np.zeros(params.n_states)
    h[0], h[2] = wall - front - sc.gap, sc.depth
    h[6:6 + n] = params.arm.stowed if sc.posture == "stowed" else params.arm.home
    a = np.radians(sc.angle)
    h[6 + n:9 + n] = [sc.speed * np.cos(a), sc.speed * np.sin(a), -sc.sink]
    ref = h.copy()
    ref[0], ref[6 + n:] = wall - front - sc.target_gap, 0.0
    return h, ref


def current_profile(sc: Scenario) -> Current:
    c, g = np.asarray(sc.current, float), np.asarray(sc.gust, float)
    if not np.any(g):
        return Current.constant(c)
    return Current(times=np.array([0.0, 1.0, 2.0]), velocities=np.array([c, c, c + g]))


def max_thrust_along(params, direction: np.ndarray) -> float:
    """The largest total thruster force [N] along a world direction at zero attitude."""
    lo, hi = params.input_bounds()
    proj = params.allocation_matrix()[:3].T @ direction
    nt = params.n_thrusters
    return float(np.sum(np.where(proj > 0, hi[:nt] * proj, lo[:nt] * proj)))


def build_plant(sc: Scenario, mismatch: str, seed: int) -> tuple[UVMSParams, Scene, Plant, dict[str, float]]:
    """The controller's parameters and scene (the files, the scenario's known current) and the
    plant drawn from the mismatch (with its unknown current and dead thrusters), plus the draw."""
    params, scene = load_params(arm=sc.arm), load_scene()
    scene = scene.with_current(current_profile(sc))
    drawn = mismatches.draw(mismatch, seed)
    plant_params, plant_scene, extra_current, unknown_dead = mismatches.apply(params, scene, drawn)
    profile = scene.current
    plant_scene = plant_scene.with_current(Current(times=profile.times, velocities=profile.velocities + extra_current))
    faults = tuple(ThrusterFault(i, sc.fail_at) for i in sc.failed_thrusters)
    faults += tuple(ThrusterFault(i, 0.0) for i in unknown_dead if i not in sc.failed_thrusters)
    return params, scene, Plant(plant_params, plant_scene, PlantSettings(faults=faults)), drawn


