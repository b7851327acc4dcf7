"""Scenes: water properties, a uniform (possibly time-varying) current and plane obstacles."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from uvms.params import ASSETS, _frozen, read_table

DEFAULT_SCENE = ASSETS / "scenes" / "wall_and_seafloor.toml"
SCENE_SCHEMA = "uvms-scene/1"


@dataclass(frozen=True)
class Water:
    """Fluid and gravity: density [kg/m^3], dynamic viscosity [Pa s], gravity [m/s^2]."""

    density: float
    viscosity: float
    gravity: float


@dataclass(frozen=True)
class Plane:
    """Obstacle plane n . x + D = 0, unit normal n pointing into the water; friction [-]."""

    name: str
    normal: np.ndarray
    offset: float  # D [m]
    friction: float

    @property
    def point(self) -> np.ndarray:
        """The point of the plane closest to the world origin [m]."""
        return -self.offset * self.normal

    def signed_distance(self, x: np.ndarray) -> np.ndarray:
        """Signed distance [m] of point(s) x (..., 3) from the plane, positive on the water side."""
        return np.asarray(x) @ self.normal + self.offset

    @classmethod
    def through(cls, name: str, point: np.ndarray, normal: np.ndarray, friction: float = 0.5) -> Plane:
        n = np.asarray(normal, dtype=float)
        n = n / np.linalg.norm(n)
        return cls(name=name, normal=_frozen(n), offset=float(-n @ np.asarray(point, float)),
                   friction=float(friction))


@dataclass(frozen=True)
class Current:
    """Uniform current, piecewise linear in time [s] -> world velocity [m/s], held after the end."""

    times: np.ndarray  # (K,) s, increasing
    velocities: np.ndarray  # (K, 3) m/s

    def at(self, t: float) -> np.ndarray:
        return np.array([np.interp(t, self.times, self.velocities[:, i]) for i in range(3)])

    @classmethod
    def constant(cls, velocity: np.ndarray | tuple[float, float, float]) -> Current:
        return cls(times=_frozen([0.0]), velocities=_frozen([velocity]))


@dataclass(frozen=True)
class Scene:
    """Water, current and obstacles."""

    name: str
    water: Water
    current: Current
    planes: tuple[Plane, ...]

    def with_current(self, current: Current) -> Scene:
        return replace(self, current=current)

    def with_planes(self, planes: tuple[Plane, ...]) -> Scene:
        return replace(self, planes=planes)


def load_scene(path: str | Path = DEFAULT_SCENE) -> Scene:
    """Load and validate a scene file.

    Raises:
        ParamError: one line naming the file, the field and what is allowed.
    """
    top = read_table(Path(path), "scene", SCENE_SCHEMA)
    name = top.string("name")
    w = top.table("water")
    water = Water(density=w.scalar("density", "kg/m^3", min_value=0.0, strict_min=True),
                  viscosity=w.scalar("viscosity", "Pa*s", min_value=0.0),
                  gravity=w.scalar("gravity", "m/s^2", min_value=0.0))
    w.finish()
    c = top.table("current")
    times = c.quantity("times", "s", (len(c.data.get("times", {}).get("value", [])),))
    if times.size == 0 or np.any(np.diff(times) <= 0):
        raise c.fail("times", "allowed: a non-empty, strictly increasing list of times")
    current = Current(times=times, velocities=c.quantity("velocities", "m/s", (times.size, 3)))
    c.finish()
    planes = []
    for p in top.tables("planes"):
        plane = Plane.through(p.string("name"), p.quantity("point", "m", (3,)),
                              p.unit_vector("normal"), p.scalar("friction", "1", min_value=0.0))
        p.finish()
        planes.append(plane)
    top.finish()
    return Scene(name=name, water=water, current=current, planes=tuple(planes))
