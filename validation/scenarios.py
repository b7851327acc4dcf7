"""Scenarios as data: one TOML file a scenario under `assets/scenarios/` (the file stem is its name),
validated on load, overridable with dotted `key=value` settings (`uvms run NAME --set ...`).

Every number in a scenario file is written with its unit, ``{ value = ..., unit = "..." }``, and the
loader checks the unit against the schema's (below). Units: lengths m, times s, speeds m/s, angles
deg, angular rates deg/s, joint angles rad, forces N, friction and plane normals 1 (dimensionless).

Schema ``uvms-scenario/1`` (keys in brackets are optional, with their defaults)::

    schema = "uvms-scenario/1"
    description = "..."                one line
    [tags] = ["avoidable", ...]        free words: unavoidable, hard, avoidable, kane, ...
    duration = { s }                   > 0
    arm = "alpha4"                     an arm variant of the vehicle file

    [scene]                            (default: the default scene file, its planes)
      [file] = "wall_and_seafloor"     a scene under assets/scenes (its water; its planes unless given)
      [[planes]]                       replace the file's planes: any number, any pose
        name = "wall"; point = { [3] m }; normal = { [3] 1 } (normalised on load); friction = { 1 }

    [initial]                          the start state h0
      position = { [3] m }             absolute, world; or the three keys below instead
      plane = "wall"; gap = { m }; depth = { m }
                                       on the plane's normal line through its `point`, the hull front
                                       (its semi-axis along body x) `gap` off the plane, at z = depth;
                                       the plane's normal must be horizontal
      [roll], [pitch], [yaw] = { deg } ZYX Euler angles (default 0)
      [velocity] = { [3] m/s }         body frame (default 0)
      [angular_velocity] = { [3] deg/s } body frame (default 0)
      [posture] = "stowed" | "home"    the arm's joints (default "stowed"); or
      [joints] = { [n] rad }           joint angles (within the joint ranges)

    [current]                          world velocity, piecewise linear in time, held after the end
      velocity = { [3] m/s }           a constant; or
      times = { [K] s }; velocities = { [K, 3] m/s }   knots (strictly increasing times, from >= 0)
                                       (default: still water)

    [[faults]]                         thrusters that fail (default: none)
      thrusters = [0, 1]               indices into the vehicle file's thrusters
      [at] = { s }                     from this time on (default 0)
      [mode] = "dead" | "stuck"        no force, or `force` whatever is commanded (default "dead")
      [force] = { N }                  the stuck force (mode "stuck" only)
      [known] = true | false           the controller is told at `at` (dead only; default: true for
                                       dead, false for stuck)

    [task]
      kind = "station" | "waypoints"
      station:   plane = "wall"; gap = { m }   the hull front `gap` off the plane (placed as the
                                                start's gap) at the start's depth; or
                 position = { [3] m }
      waypoints: times = { [K] s }; positions = { [K, 3] m }   the reference position is piecewise
                                                linear in time, held before the first and after the last
      [roll], [pitch], [yaw] = { deg }  the reference attitude (default: the start's)
                                        The reference holds the start's arm posture and zero velocities.

Overrides (`Scenario.with_overrides`, `uvms run --set`): `key=value` with a dotted key into the
table above (`initial.pitch=15`, `current.velocity=0.1,0.4,0`, `duration=2`, `faults.0.at=1`;
an index one past the end of an array of tables adds a table). Numbers take the schema's unit;
vectors are comma-separated, matrices rows separated by `;`. Setting one form of an alternative
(`initial.position` against `initial.plane/gap/depth`, `current.velocity` against
`current.times/velocities`, `initial.posture` against `initial.joints`, a station task's
`position` against its `plane/gap` against a waypoint task's `times/positions`) removes the other;
the value `none` removes a key (or all tables of an array). The overridden data is then validated
like a file.
"""

from __future__ import annotations

import contextlib
import functools
import tomllib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from uvms.params import ASSETS, ParamError, arm_variants, load_params

SCENARIO_DIR = ASSETS / "scenarios"
SCENE_DIR = ASSETS / "scenes"
SCHEMA = "uvms-scenario/1"
DEFAULT_SCENE_FILE = "wall_and_seafloor"
POSTURES = ("stowed", "home")
Vec3 = tuple[float, float, float]


# --------------------------------------------------------------------------------------------
# The scenario tree (every field frozen; numbers in the units of the field's comment).


@dataclass(frozen=True)
class PlaneSpec:
    """An obstacle plane: a point on it [m], its unit normal pointing into the water, friction [-]."""

    name: str
    point: Vec3
    normal: Vec3
    friction: float


@dataclass(frozen=True)
class SceneSpec:
    """The scene file under assets/scenes (its water) and, if any, the planes that replace its own."""

    file: str = DEFAULT_SCENE_FILE
    planes: tuple[PlaneSpec, ...] = ()


@dataclass(frozen=True)
class Initial:
    """The start state. Position: `position` [m] or (`plane`, `gap` [m], `depth` [m]); attitude
    [deg] (ZYX Euler); body-frame velocity [m/s] and angular velocity [deg/s]; arm: `posture` by
    name or `joints` [rad]."""

    position: Vec3 | None = None
    plane: str | None = None
    gap: float | None = None
    depth: float | None = None
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0
    velocity: Vec3 = (0.0, 0.0, 0.0)
    angular_velocity: Vec3 = (0.0, 0.0, 0.0)
    posture: str | None = "stowed"
    joints: tuple[float, ...] | None = None


@dataclass(frozen=True)
class CurrentSpec:
    """A uniform current: knots at `times` [s] with world `velocities` [m/s], linear in between and
    held after the last; one knot is a constant. `constant` records the file's form."""

    times: tuple[float, ...] = (0.0,)
    velocities: tuple[Vec3, ...] = ((0.0, 0.0, 0.0),)
    constant: bool = True

    def at(self, t: float) -> np.ndarray:
        """The velocity [m/s] at time t [s]."""
        v = np.asarray(self.velocities, float)
        return np.array([np.interp(t, self.times, v[:, i]) for i in range(3)])


@dataclass(frozen=True)
class Fault:
    """Thrusters that fail from `at` [s] on: "dead" (no force) or "stuck" at `force` [N]; `known`: the
    controller is told at that time."""

    thrusters: tuple[int, ...]
    at: float = 0.0
    mode: Literal["dead", "stuck"] = "dead"
    force: float | None = None
    known: bool = True


@dataclass(frozen=True)
class Task:
    """Station keeping at `position` [m] or `gap` [m] off `plane`, or `waypoints`: positions [m] at
    times [s]; the reference attitude [deg] (None: the start's)."""

    kind: Literal["station", "waypoints"]
    plane: str | None = None
    gap: float | None = None
    position: Vec3 | None = None
    times: tuple[float, ...] | None = None
    positions: tuple[Vec3, ...] | None = None
    roll: float | None = None
    pitch: float | None = None
    yaw: float | None = None


@dataclass(frozen=True)
class Scenario:
    """One closed-loop scenario (the module docstring has the file schema); `duration` [s]."""

    name: str
    description: str
    duration: float
    arm: str
    initial: Initial
    task: Task
    tags: tuple[str, ...] = ()
    scene: SceneSpec = SceneSpec()
    current: CurrentSpec = CurrentSpec()
    faults: tuple[Fault, ...] = ()
    file: str = field(default="", compare=False, repr=False)  # the file it was read from (for messages)

    def known_dead(self, t: float) -> tuple[int, ...]:
        """The thrusters the controller knows to be dead at time t [s] (within 1e-9 s of `at`)."""
        return tuple(i for f in self.faults if f.known and f.mode == "dead" and t >= f.at - 1e-9
                     for i in f.thrusters)

    def to_data(self) -> dict[str, Any]:
        """The scenario as the TOML data of its file (loadable with `parse`)."""
        return _dump(self)

    def with_overrides(self, overrides: Mapping[str, str]) -> Scenario:
        """A copy with dotted `key=value` overrides (module docstring), validated like a file.

        Raises:
            ParamError: one line: the unknown key and the allowed ones, a malformed value and what
                is allowed, or the file's field that the result breaks.
        """
        data = self.to_data()
        for key, text in overrides.items():
            _override(data, key, text)
        return parse(data, self.name, Path(self.file or f"{self.name}.toml"))


# --------------------------------------------------------------------------------------------
# The schema: kinds of leaves, tables as dicts, arrays of tables as one-element lists.


@dataclass(frozen=True)
class _Q:
    """A number or array with its unit; `shape` entries None: any length."""

    unit: str
    shape: tuple[int | None, ...] = ()


_STR, _STRS, _INTS, _BOOL = "a string", "comma-separated words", "comma-separated integers", "true or false"
_ATTITUDE = {"roll": _Q("deg"), "pitch": _Q("deg"), "yaw": _Q("deg")}
_SCHEMA: dict[str, Any] = {
    "schema": _STR, "description": _STR, "tags": _STRS, "duration": _Q("s"), "arm": _STR,
    "scene": {"file": _STR, "planes": [{"name": _STR, "point": _Q("m", (3,)), "normal": _Q("1", (3,)),
                                        "friction": _Q("1")}]},
    "initial": {"position": _Q("m", (3,)), "plane": _STR, "gap": _Q("m"), "depth": _Q("m"), **_ATTITUDE,
                "velocity": _Q("m/s", (3,)), "angular_velocity": _Q("deg/s", (3,)), "posture": _STR,
                "joints": _Q("rad", (None,))},
    "current": {"velocity": _Q("m/s", (3,)), "times": _Q("s", (None,)), "velocities": _Q("m/s", (None, 3))},
    "faults": [{"thrusters": _INTS, "at": _Q("s"), "mode": _STR, "force": _Q("N"), "known": _BOOL}],
    "task": {"kind": _STR, "plane": _STR, "gap": _Q("m"), "position": _Q("m", (3,)), "times": _Q("s", (None,)),
             "positions": _Q("m", (None, 3)), **_ATTITUDE},
}
# Alternatives: per table, settings with two or more forms; setting (by override) a key of one form
# removes the keys of the setting's other forms.
_ALTERNATIVES: dict[str, tuple[tuple[frozenset[str], ...], ...]] = {
    "initial": ((frozenset({"position"}), frozenset({"plane", "gap", "depth"})),
                (frozenset({"posture"}), frozenset({"joints"}))),
    "current": ((frozenset({"velocity"}), frozenset({"times", "velocities"})),),
    "task": ((frozenset({"position"}), frozenset({"plane", "gap"}), frozenset({"times", "positions"})),),
}


def _keys(schema: dict[str, Any], prefix: str = "") -> list[str]:
    out = []
    for k, v in schema.items():
        if isinstance(v, dict):
            out += _keys(v, f"{prefix}{k}.")
        elif isinstance(v, list):
            out += _keys(v[0], f"{prefix}{k}.N.")
        else:
            out.append(prefix + k)
    return out


ALLOWED_KEYS: tuple[str, ...] = tuple(k for k in _keys(_SCHEMA) if k != "schema")


# --------------------------------------------------------------------------------------------
# Reading: a table that knows its file and dotted path (one-line errors, unknown keys rejected).


@dataclass
class _Reader:
    data: dict[str, Any]
    file: Path
    path: str
    schema: dict[str, Any]
    used: set[str] = field(default_factory=set)

    def where(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def fail(self, key: str, msg: str) -> ParamError:
        return ParamError(f"{self.file.name}: {self.where(key)}: {msg}")

    def has(self, key: str) -> bool:
        return key in self.data

    def _get(self, key: str) -> Any:
        if key not in self.data:
            raise self.fail(key, "missing key")
        self.used.add(key)
        return self.data[key]

    def table(self, key: str) -> _Reader:
        v = self._get(key) if key in self.data else {}
        if not isinstance(v, dict):
            raise self.fail(key, f"a {type(v).__name__} is not allowed; allowed: a table")
        return _Reader(v, self.file, self.where(key), self.schema[key])

    def tables(self, key: str) -> list[_Reader]:
        v = self._get(key) if key in self.data else []
        if not isinstance(v, list) or not all(isinstance(t, dict) for t in v):
            raise self.fail(key, "allowed: an array of tables ([[...]])")
        return [_Reader(t, self.file, f"{self.where(key)}[{i}]", self.schema[key][0]) for i, t in enumerate(v)]

    def string(self, key: str, allowed: tuple[str, ...] | None = None) -> str:
        v = self._get(key)
        if not isinstance(v, str) or not v:
            raise self.fail(key, f"{v!r} is not allowed; allowed: a non-empty string")
        if allowed is not None and v not in allowed:
            raise self.fail(key, f"{v!r} is not allowed; allowed: {', '.join(allowed)}")
        return v

    def strings(self, key: str) -> tuple[str, ...]:
        v = self._get(key)
        if not isinstance(v, list) or not all(isinstance(s, str) and s for s in v):
            raise self.fail(key, f"{v!r} is not allowed; allowed: a list of non-empty strings")
        return tuple(v)

    def ints(self, key: str, lo: int, hi: int) -> tuple[int, ...]:
        v = self._get(key)
        if (not isinstance(v, list) or not v or not all(isinstance(i, int) and not isinstance(i, bool) for i in v)
                or not all(lo <= i <= hi for i in v) or len(set(v)) != len(v)):
            raise self.fail(key, f"{v!r} is not allowed; allowed: a non-empty list of distinct integers {lo}..{hi}")
        return tuple(v)

    def boolean(self, key: str) -> bool:
        v = self._get(key)
        if not isinstance(v, bool):
            raise self.fail(key, f"{v!r} is not allowed; allowed: true or false")
        return v

    def quantity(self, key: str, *, min_value: float | None = None, strict_min: bool = False,
                 length: int | None = None) -> np.ndarray:
        """`{ value = ..., unit = "..." }` in the schema's unit and shape (`length`: the shape's free
        first dimension), finite, within range."""
        spec: _Q = self.schema[key]
        q = self._get(key)
        if not isinstance(q, dict) or set(q) != {"value", "unit"}:
            raise self.fail(key, f'{q!r} is not allowed; allowed: {{ value = ..., unit = "{spec.unit}" }}')
        if q["unit"] != spec.unit:
            raise self.fail(key, f"unit {q['unit']!r} is not allowed; allowed: {spec.unit!r}")
        try:
            arr = np.array(q["value"], dtype=float)
        except (TypeError, ValueError):
            raise self.fail(key, "allowed: a number or a rectangular array of numbers") from None
        shape = tuple(length if s is None else s for s in spec.shape)
        ok = arr.ndim == len(shape) and all(s is None or a == s for a, s in zip(arr.shape, shape, strict=False))
        if not ok or (spec.shape[:1] == (None,) and arr.size == 0):
            want = "x".join("K" if s is None else str(s) for s in shape) or "a number"
            raise self.fail(key, f"shape {arr.shape} is not allowed; allowed: {want} (non-empty)")
        if not np.all(np.isfinite(arr)):
            raise self.fail(key, "allowed: finite numbers")
        if min_value is not None and np.any(arr <= min_value if strict_min else arr < min_value):
            raise self.fail(key, f"value {arr.tolist()} out of range; allowed: {'>' if strict_min else '>='} "
                                 f"{min_value} {spec.unit}")
        return arr

    def number(self, key: str, **kw: Any) -> float:
        return float(self.quantity(key, **kw))

    def vec3(self, key: str) -> Vec3:
        x, y, z = (float(v) for v in self.quantity(key))
        return (x, y, z)

    def finish(self) -> None:
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            raise self.fail(unknown[0], f"unknown key; allowed: {', '.join(self.schema)}")


def _increasing(r: _Reader, key: str, values: np.ndarray) -> tuple[float, ...]:
    if values[0] < 0.0 or np.any(np.diff(values) <= 0.0):
        raise r.fail(key, f"{values.tolist()} is not allowed; allowed: strictly increasing times from >= 0 s")
    return tuple(float(t) for t in values)


def _rows(a: np.ndarray) -> tuple[Vec3, ...]:
    return tuple((float(x), float(y), float(z)) for x, y, z in a)


def _only(r: _Reader, groups: tuple[set[str], ...], what: str) -> int | None:
    """Which of the alternative key groups the table uses (None: none), or a one-line error."""
    present = [i for i, g in enumerate(groups) if any(r.has(k) for k in g)]
    if len(present) > 1:
        a, b = (sorted(groups[i])[0] for i in present[:2])
        raise r.fail(a, f"{a} and {b} are alternatives; allowed: {what}")
    if present and not all(r.has(k) for k in groups[present[0]]):
        missing = sorted(k for k in groups[present[0]] if not r.has(k))[0]
        raise r.fail(missing, f"missing key; allowed: {what}")
    return present[0] if present else None


@functools.cache
def _vehicle(arm: str) -> tuple[int, int, tuple[tuple[float, float], ...]]:
    """The arm variant's thruster count, joint count and joint ranges [rad]."""
    p = load_params(arm=arm)
    return p.n_thrusters, p.n_joints, tuple((float(lk.joint_range[0]), float(lk.joint_range[1]))
                                            for lk in p.arm.links)


def _scene_planes(file: str) -> dict[str, np.ndarray]:
    """The scene file's planes by name: their unit normals."""
    from uvms.scene import load_scene

    return {p.name: p.normal for p in load_scene(SCENE_DIR / f"{file}.toml").planes}


def _plane_ref(r: _Reader, normals: dict[str, np.ndarray]) -> tuple[str, float]:
    plane = r.string("plane", tuple(normals))
    if abs(normals[plane][2]) > 1e-9:
        raise r.fail("plane", f"{plane!r} has a normal with a vertical part; allowed: a plane with a "
                              "horizontal normal (a wall) for a gap, or a position")
    return plane, r.number("gap")


def _attitude(r: _Reader, default: float | None) -> dict[str, float | None]:
    return {k: (r.number(k) if r.has(k) else default) for k in ("roll", "pitch", "yaw")}


def parse(data: dict[str, Any], name: str, file: Path) -> Scenario:
    """A Scenario from a file's TOML data (or data built or overridden in code).

    Raises:
        ParamError: one line naming the file, the field and what is allowed.
    """
    top = _Reader(data, file, "", _SCHEMA)
    top.string("schema", (SCHEMA,))
    description = top.string("description")
    tags = top.strings("tags") if top.has("tags") else ()
    duration = top.number("duration", min_value=0.0, strict_min=True)
    arm = top.string("arm", arm_variants())
    n_thrusters, n_joints, ranges = _vehicle(arm)

    s = top.table("scene")
    scene_files = tuple(sorted(p.stem for p in SCENE_DIR.glob("*.toml")))
    scene_file = s.string("file", scene_files) if s.has("file") else DEFAULT_SCENE_FILE
    planes = []
    for p in s.tables("planes"):
        normal = p.quantity("normal")
        if np.linalg.norm(normal) < 1e-9:
            raise p.fail("normal", "a zero vector is not allowed; allowed: a non-zero vector (normalised on load)")
        normal = normal / np.linalg.norm(normal)
        planes.append(PlaneSpec(p.string("name"), p.vec3("point"), (float(normal[0]), float(normal[1]),
                                                                     float(normal[2])),
                                p.number("friction", min_value=0.0)))
        p.finish()
    if len({p.name for p in planes}) != len(planes):
        raise s.fail("planes", "plane names repeat; allowed: distinct names")
    s.finish()
    normals = ({p.name: np.asarray(p.normal) for p in planes} if planes else _scene_planes(scene_file))

    i = top.table("initial")
    where = _only(i, ({"position"}, {"plane", "gap", "depth"}), "position, or plane + gap + depth")
    if where is None:
        raise i.fail("position", "missing key; allowed: position, or plane + gap + depth")
    position = i.vec3("position") if where == 0 else None
    plane, gap = _plane_ref(i, normals) if where == 1 else (None, None)
    depth = i.number("depth") if where == 1 else None
    arm_form = _only(i, ({"posture"}, {"joints"}), "posture or joints")
    posture = i.string("posture", POSTURES) if arm_form == 0 else ("stowed" if arm_form is None else None)
    joints = None
    if arm_form == 1:
        q = i.quantity("joints", length=n_joints)
        for k, (qk, (lo, hi)) in enumerate(zip(q, ranges, strict=True)):
            if not lo <= qk <= hi:
                raise i.fail("joints", f"joint {k} at {qk} rad is outside its range [{lo}, {hi}]; allowed: within it")
        joints = tuple(float(v) for v in q)
    initial = Initial(position=position, plane=plane, gap=gap, depth=depth,
                      **_attitude(i, 0.0),  # type: ignore[arg-type]
                      velocity=i.vec3("velocity") if i.has("velocity") else (0.0, 0.0, 0.0),
                      angular_velocity=i.vec3("angular_velocity") if i.has("angular_velocity") else (0.0, 0.0, 0.0),
                      posture=posture, joints=joints)
    i.finish()

    c = top.table("current")
    form = _only(c, ({"velocity"}, {"times", "velocities"}), "velocity, or times + velocities")
    if form == 1:
        times = _increasing(c, "times", c.quantity("times"))
        current = CurrentSpec(times, _rows(c.quantity("velocities", length=len(times))), constant=False)
    else:
        current = CurrentSpec(velocities=(c.vec3("velocity"),) if form == 0 else ((0.0, 0.0, 0.0),))
    c.finish()

    faults, seen = [], set()
    for f in top.tables("faults"):
        thrusters = f.ints("thrusters", 0, n_thrusters - 1)
        if seen & set(thrusters):
            raise f.fail("thrusters", f"thruster {sorted(seen & set(thrusters))[0]} fails twice; allowed: each "
                                      "thruster in one fault")
        seen |= set(thrusters)
        mode = f.string("mode", ("dead", "stuck")) if f.has("mode") else "dead"
        if mode == "dead" and f.has("force"):
            raise f.fail("force", "a dead thruster has no force; allowed: force with mode = \"stuck\"")
        force = f.number("force") if mode == "stuck" else None
        known = f.boolean("known") if f.has("known") else mode == "dead"
        if known and mode == "stuck":
            raise f.fail("known", "the controller can be told only of dead thrusters; allowed: known = false "
                                  "with mode = \"stuck\"")
        faults.append(Fault(thrusters, f.number("at", min_value=0.0) if f.has("at") else 0.0, mode, force, known))
        f.finish()

    t = top.table("task")
    kind = t.string("kind", ("station", "waypoints"))
    form = _only(t, ({"position"}, {"plane", "gap"}, {"times", "positions"}),
                 "position, or plane + gap (station); times + positions (waypoints)")
    if (kind == "station") != (form in (0, 1)):
        raise t.fail("kind", f"{kind!r} with these keys is not allowed; allowed: station with position, or plane "
                             "+ gap; waypoints with times + positions")
    task_plane, task_gap = _plane_ref(t, normals) if form == 1 else (None, None)
    times = _increasing(t, "times", t.quantity("times")) if form == 2 else None
    task = Task(kind=kind, plane=task_plane, gap=task_gap,  # type: ignore[arg-type]
                position=t.vec3("position") if form == 0 else None, times=times,
                positions=_rows(t.quantity("positions", length=len(times))) if times else None,
                **_attitude(t, None))
    t.finish()
    top.finish()
    return Scenario(name=name, description=description, duration=duration, arm=arm, initial=initial, task=task,
                    tags=tags, scene=SceneSpec(scene_file, tuple(planes)), current=current, faults=tuple(faults),
                    file=str(file))


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario file (its stem is the name).

    Raises:
        ParamError: one line naming the file, the field and what is allowed.
    """
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ParamError(f"{path}: no such scenario file") from None
    except tomllib.TOMLDecodeError as e:
        raise ParamError(f"{path.name}: not valid TOML: {e}") from None
    return parse(raw, path.stem, path)


# --------------------------------------------------------------------------------------------
# Writing back (the data of a file) and overrides.


def _q(value: Any, unit: str) -> dict[str, Any]:
    return {"value": [list(v) if isinstance(v, tuple) else v for v in value] if isinstance(value, tuple) else value,
            "unit": unit}


def _dump(sc: Scenario) -> dict[str, Any]:
    d: dict[str, Any] = {"schema": SCHEMA, "description": sc.description, "tags": list(sc.tags),
                         "duration": _q(sc.duration, "s"), "arm": sc.arm}
    d["scene"] = {"file": sc.scene.file}
    if sc.scene.planes:
        d["scene"]["planes"] = [{"name": p.name, "point": _q(p.point, "m"), "normal": _q(p.normal, "1"),
                                 "friction": _q(p.friction, "1")} for p in sc.scene.planes]
    ini = sc.initial
    i: dict[str, Any] = {}
    if ini.position is not None:
        i["position"] = _q(ini.position, "m")
    else:
        i.update(plane=ini.plane, gap=_q(ini.gap, "m"), depth=_q(ini.depth, "m"))
    i.update(roll=_q(ini.roll, "deg"), pitch=_q(ini.pitch, "deg"), yaw=_q(ini.yaw, "deg"),
             velocity=_q(ini.velocity, "m/s"), angular_velocity=_q(ini.angular_velocity, "deg/s"))
    if ini.joints is not None:
        i["joints"] = _q(ini.joints, "rad")
    else:
        i["posture"] = ini.posture
    d["initial"] = i
    cur = sc.current
    d["current"] = ({"velocity": _q(cur.velocities[0], "m/s")} if cur.constant else
                    {"times": _q(cur.times, "s"), "velocities": _q(cur.velocities, "m/s")})
    d["faults"] = [{"thrusters": list(f.thrusters), "at": _q(f.at, "s"), "mode": f.mode, "known": f.known,
                    **({"force": _q(f.force, "N")} if f.force is not None else {})} for f in sc.faults]
    task = sc.task
    t: dict[str, Any] = {"kind": task.kind}
    if task.position is not None:
        t["position"] = _q(task.position, "m")
    if task.plane is not None:
        t.update(plane=task.plane, gap=_q(task.gap, "m"))
    if task.times is not None:
        t.update(times=_q(task.times, "s"), positions=_q(task.positions, "m"))
    for k in ("roll", "pitch", "yaw"):
        if getattr(task, k) is not None:
            t[k] = _q(getattr(task, k), "deg")
    d["task"] = t
    return d


def _value(key: str, spec: Any, text: str) -> Any:
    """The TOML value of an override's text for a schema leaf, or a one-line error."""
    text = text.strip()
    with contextlib.suppress(ValueError, KeyError):  # malformed: the one-line error below
        if isinstance(spec, _Q):
            if len(spec.shape) == 2:
                value: Any = [[float(x) for x in row.split(",")] for row in text.split(";")]
                if any(len(r) != spec.shape[1] for r in value):
                    raise ValueError
            elif spec.shape:
                value = [float(x) for x in text.split(",")]
            else:
                value = float(text)
            return {"value": value, "unit": spec.unit}
        if spec == _INTS:
            return [int(x) for x in text.split(",")]
        if spec == _STRS:
            return [w.strip() for w in text.split(",") if w.strip()]
        if spec == _BOOL:
            return {"true": True, "false": False}[text.lower()]
        return text
    if isinstance(spec, _Q):
        kind = ("rows of 3 comma-separated numbers separated by ';'" if len(spec.shape) == 2 else
                "comma-separated numbers" if spec.shape else "a number")
        allowed = f"{kind} in {spec.unit}"
    else:
        allowed = spec
    raise ParamError(f"setting {key}={text!r} is malformed; allowed: {allowed} (or none)")


def _override(data: dict[str, Any], key: str, text: str) -> None:
    """Apply one dotted override to a file's data in place (module docstring)."""
    unknown = ParamError(f"unknown setting {key!r}; allowed: {', '.join(ALLOWED_KEYS)}")
    parts = key.split(".")
    node, schema = data, _SCHEMA
    for k, part in enumerate(parts):
        if part not in schema or part == "schema":
            raise unknown
        spec, last = schema[part], k == len(parts) - 1
        if last and (isinstance(spec, list) or not isinstance(spec, dict)):
            if text.strip() == "none":
                node.pop(part, None)
                return
            if isinstance(spec, list):
                raise ParamError(f"setting {key}={text!r} is malformed; allowed: none (or set {key}.N.KEY)")
            value = _value(key, spec, text)
            for forms in _ALTERNATIVES.get(parts[-2] if len(parts) > 1 else "", ()):
                for other in (g for g in forms if any(part in g for g in forms) and part not in g):
                    for o in other:
                        node.pop(o, None)
            node[part] = value
            return
        if last:
            raise unknown
        if isinstance(spec, dict):
            child = node.setdefault(part, {})
            if not isinstance(child, dict):
                raise unknown
            node, schema = child, spec
            continue
        items = node.setdefault(part, [])
        index = parts[k + 1] if k + 1 < len(parts) else ""
        if not index.isdigit() or int(index) > len(items) or k + 2 >= len(parts):
            raise ParamError(f"setting {key!r}: allowed: {part}.N.KEY with N from 0 to {len(items)} "
                             f"(N = {len(items)} adds one) and KEY one of {', '.join(spec[0])}")
        if int(index) == len(items):
            items.append({})
        rest = ".".join(parts[k + 2:])
        _override_table(items[int(index)], spec[0], rest, key, text)
        return
    raise unknown


def _override_table(node: dict[str, Any], schema: dict[str, Any], rest: str, key: str, text: str) -> None:
    part = rest
    if "." in rest or part not in schema:
        raise ParamError(f"unknown setting {key!r}; allowed: {', '.join(ALLOWED_KEYS)}")
    if text.strip() == "none":
        node.pop(part, None)
    else:
        node[part] = _value(key, schema[part], text)


# --------------------------------------------------------------------------------------------
# The registry: every file under assets/scenarios, loaded when first asked for.


class Registry(Mapping[str, Scenario]):
    """The scenario files of a folder by name (sorted), each loaded and validated on first use."""

    def __init__(self, folder: Path = SCENARIO_DIR):
        self.folder = folder
        self._loaded: dict[str, Scenario] = {}

    def _names(self) -> list[str]:
        return sorted(p.stem for p in self.folder.glob("*.toml"))

    def __getitem__(self, name: str) -> Scenario:
        if name not in self._loaded:
            path = self.folder / f"{name}.toml"
            if not path.is_file():
                raise KeyError(name)
            self._loaded[name] = load_scenario(path)
        return self._loaded[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())

    def __len__(self) -> int:
        return len(self._names())

    def tagged(self, tag: str) -> dict[str, Scenario]:
        """The scenarios with a tag, by name."""
        return {n: sc for n, sc in self.items() if tag in sc.tags}


SCENARIOS = Registry()


def get(name: str) -> Scenario:
    """A scenario by its file's name, or a one-line ValueError listing the names."""
    if name not in SCENARIOS:
        raise ValueError(f"unknown scenario {name!r}; allowed: {', '.join(SCENARIOS)}")
    return SCENARIOS[name]


def wall_approach(gap: float, speed: float) -> Scenario:
    """avoid-wall with the hull front `gap` [m] off the wall, moving at `speed` [m/s] along body x
    (towards the wall) at the start."""
    return get("avoid-wall").with_overrides({"initial.gap": repr(gap), "initial.velocity": f"{speed!r},0,0"})


__all__ = ["ALLOWED_KEYS", "SCENARIOS", "CurrentSpec", "Fault", "Initial", "PlaneSpec", "Registry", "Scenario",
           "SceneSpec", "Task", "get", "load_scenario", "parse", "wall_approach"]
