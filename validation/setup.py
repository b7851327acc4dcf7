"""From a scenario to the closed loop's inputs: the scene, the start state, the task's reference, the
current profile and the plant with its faults (the mechanisms; the scenario files hold the settings)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from uvms import load_params, load_scene
from uvms.params import UVMSParams, _frozen
from uvms.scene import Current, Plane, Scene
from uvms_mj.plant import FaultMode, Plant, PlantSettings, ThrusterFault
from validation import mismatch as mismatches
from validation.scenarios import POSTURES, SCENE_DIR, Scenario

Reference = np.ndarray | Callable[[float], np.ndarray]


def wall_x() -> float:
    """x [m] of the default scene's wall (read from the scene file: numbers live there once)."""
    return float(next(p for p in load_scene().planes if p.name == "wall").point[0])


def current_profile(sc: Scenario) -> Current:
    """The scenario's current [m/s, world] as the scene's piecewise-linear profile."""
    return Current(times=_frozen(sc.current.times), velocities=_frozen(sc.current.velocities))


def scene_of(sc: Scenario) -> Scene:
    """The scenario's scene: its scene file's water, the file's planes or the scenario's own, and
    the scenario's current."""
    scene = load_scene(SCENE_DIR / f"{sc.scene.file}.toml")
    if sc.scene.planes:
        scene = scene.with_planes(tuple(Plane.through(p.name, np.array(p.point), np.array(p.normal), p.friction)
                                        for p in sc.scene.planes))
    return scene.with_current(current_profile(sc))


def _facing(params: UVMSParams, plane: Plane, gap: float) -> np.ndarray:
    """The hull centre [m] on the plane's normal line through its point, the hull front (the
    semi-axis along body x) `gap` [m] off the plane (the vehicle facing it); z to be set by the
    caller. (Summed in this order, an axis-aligned plane gives point - front - gap exactly.)"""
    front = params.hull.superellipsoid.semi_axes[0]
    return (plane.point + plane.normal * front) + plane.normal * gap


def _plane(scene: Scene, name: str) -> Plane:
    return next(p for p in scene.planes if p.name == name)


def initial_state(params: UVMSParams, sc: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """The start state h0 and the task's reference state at the end of the run (the reference
    itself: `reference`)."""
    h0 = _start(params, sc, scene_of(sc))
    ref = reference(params, sc)
    return h0, ref(sc.duration) if callable(ref) else ref


def _start(params: UVMSParams, sc: Scenario, scene: Scene) -> np.ndarray:
    n, ini = params.n_joints, sc.initial
    h = np.zeros(params.n_states)
    if ini.position is not None:
        h[:3] = ini.position
    else:
        h[:3] = _facing(params, _plane(scene, ini.plane), ini.gap)
        h[2] = ini.depth
    h[3:6] = np.radians([ini.roll, ini.pitch, ini.yaw])
    if ini.joints is not None:
        h[6:6 + n] = ini.joints
    elif ini.posture not in POSTURES:
        raise ValueError(f"posture {ini.posture!r}; allowed: {', '.join(POSTURES)}")
    else:
        h[6:6 + n] = params.arm.stowed if ini.posture == "stowed" else params.arm.home
    h[6 + n:9 + n] = ini.velocity
    h[9 + n:12 + n] = np.radians(ini.angular_velocity)
    return h


def reference(params: UVMSParams, sc: Scenario) -> Reference:
    """The task's reference: a state h_ref (station keeping) or a function of time t [s] returning
    one (waypoints). It holds the start's arm posture, the task's attitude (default: the start's)
    and zero velocities; a station at a gap keeps the start's depth."""
    scene = scene_of(sc)
    h0 = _start(params, sc, scene)
    n, task = params.n_joints, sc.task
    base = h0.copy()
    base[6 + n:] = 0.0
    for k, angle in enumerate((task.roll, task.pitch, task.yaw)):
        if angle is not None:
            base[3 + k] = np.radians(angle)
    if task.kind == "station":
        if task.position is not None:
            base[:3] = task.position
        else:
            base[:2] = _facing(params, _plane(scene, task.plane), task.gap)[:2]
        return base
    times, positions = np.asarray(task.times), np.asarray(task.positions)

    def at(t: float) -> np.ndarray:
        ref = base.copy()
        ref[:3] = [np.interp(t, times, positions[:, i]) for i in range(3)]
        return ref

    return at


def plant_faults(sc: Scenario, unknown_dead: Sequence[int] = ()) -> tuple[ThrusterFault, ...]:
    """The plant's thruster faults: the scenario's, in file order, then the mismatch's unknown dead
    thrusters (from t = 0) that the scenario does not already fail."""
    faults = tuple(ThrusterFault(i, f.at, FaultMode.ZERO if f.mode == "dead" else FaultMode.STUCK,
                                 f.force if f.force is not None else 0.0) for f in sc.faults for i in f.thrusters)
    named = {f.thruster for f in faults}
    return faults + tuple(ThrusterFault(i, 0.0) for i in unknown_dead if i not in named)


def build_plant(sc: Scenario, mismatch: str, seed: int) -> tuple[UVMSParams, Scene, Plant, dict[str, float]]:
    """The controller's parameters and scene (the files, the scenario's known current) and the
    plant drawn from the mismatch (with its unknown current and dead thrusters), plus the draw."""
    params, scene = load_params(arm=sc.arm), scene_of(sc)
    drawn = mismatches.draw(mismatch, seed)
    plant_params, plant_scene, extra_current, unknown_dead = mismatches.apply(params, scene, drawn)
    profile = scene.current
    plant_scene = plant_scene.with_current(Current(times=profile.times, velocities=profile.velocities + extra_current))
    return params, scene, Plant(plant_params, plant_scene, PlantSettings(faults=plant_faults(sc, unknown_dead))), drawn
