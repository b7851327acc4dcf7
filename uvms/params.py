"""Vehicle parameters: load `assets/*.toml` into frozen dataclasses, validating every field.

This is the one source of vehicle numbers for the controller and the plant. Every number in the
file is written as ``{ value = ..., unit = "...", source = "..." }``; the loader checks the unit
against the one this schema expects, the shape, the allowed range, and rejects unknown or missing
keys with one line naming the file, the field and what is allowed.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

ASSETS = Path(__file__).resolve().parent.parent / "assets"
DEFAULT_VEHICLE = ASSETS / "bluerov2_heavy_alpha.toml"
VEHICLE_SCHEMA = "uvms-vehicle/1"


class ParamError(ValueError):
    """A parameter file is malformed; the message is one line: file, field, what is allowed."""


def _frozen(a: Any) -> np.ndarray:
    arr = np.array(a, dtype=float)
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True)
class Superellipsoid:
    """Paper's superellipsoid: semi-axes (a, b, c) [m], eps1 (x-y exponent), eps2 (z exponent)."""

    semi_axes: np.ndarray
    eps1: float
    eps2: float


@dataclass(frozen=True)
class TrimMass:
    """A trim element (foam or ballast) of the hull: a point mass [kg] with a volume [m^3] at a
    body-frame position [m]."""

    name: str
    mass: float
    volume: float
    position: np.ndarray


@dataclass(frozen=True)
class Hull:
    """Vehicle hull AS TRIMMED: the file's hull with its trim elements folded in. Vectors in the
    body frame (x forward, y left, z up); added mass and damping are about the body origin."""

    mass: float  # kg
    inertia: np.ndarray  # (3, 3) kg m^2, about the CoM, body axes
    com: np.ndarray  # (3,) m
    volume: float  # m^3, displaced
    cob: np.ndarray  # (3,) m
    size: np.ndarray  # (3,) m, length x width x height
    arm_mount: np.ndarray  # (3,) m, position of the first joint
    superellipsoid: Superellipsoid
    added_mass: np.ndarray  # (6,) kg, kg, kg, kg m^2 x3 (Fossen, diagonal)
    linear_damping: np.ndarray  # (6,) N s/m x3, N m s/rad x3
    quadratic_damping: np.ndarray  # (6,) N s^2/m^2 x3, N m s^2/rad^2 x3
    mujoco_fluidcoef: np.ndarray  # (5,) plant only
    trim: tuple[TrimMass, ...]  # already included in mass, inertia, com, volume, cob


@dataclass(frozen=True)
class Thruster:
    """A thruster: position [m] and unit thrust direction in the body frame, force range [N]."""

    name: str
    position: np.ndarray
    direction: np.ndarray
    force_range: np.ndarray  # (2,) N: min, max


@dataclass(frozen=True)
class Link:
    """An arm link and the revolute joint that moves it (see the TOML header for frames)."""

    name: str
    joint_axis: np.ndarray  # (3,) unit, in the link frame (= parent frame at q = 0)
    joint_range: np.ndarray  # (2,) rad
    torque_limit: float  # N m, symmetric
    rotor_inertia: float  # kg m^2, motor inertia reflected through the gearbox (joint armature)
    joint_damping: float  # N m s/rad, the plant's (the controller's model with ModelOptions.joint_damping)
    length: float  # m
    radius: float  # m
    mass: float  # kg
    com: np.ndarray  # (3,) m, link frame
    inertia: np.ndarray  # (3,) kg m^2, principal about the CoM, link axes
    volume: float  # m^3
    cob: np.ndarray  # (3,) m, link frame
    superellipsoid: Superellipsoid
    added_mass_coefficient: float  # -, cross-flow
    drag_coefficient: float  # -, cross-flow
    mujoco_fluidcoef: np.ndarray  # (5,) plant only

    def added_mass(self, rho: float) -> np.ndarray:
        """Cross-flow added mass about the link's centre, link axes (the link along x) [kg x3,
        kg m^2 x3]: m_t = C_a rho pi r^2 l across the axis, m_t l^2 / 12 about the transverse axes,
        none along or about the axis."""
        mt = self.added_mass_coefficient * rho * np.pi * self.radius**2 * self.length
        return np.array([0.0, mt, mt, 0.0, mt * self.length**2 / 12, mt * self.length**2 / 12])


@dataclass(frozen=True)
class Arm:
    """A serial arm: links from base to tip, home posture [rad], end-effector point [m]."""

    name: str
    links: tuple[Link, ...]
    home: np.ndarray  # rad
    stowed: np.ndarray  # rad, folded for transit (the paper's "arm stowed")
    end_effector: np.ndarray  # (3,) m, in the last link's frame
    tip_radius: float  # m
    tip_force_limit: float  # N, largest contact force the jaws may take
    # The tip's soft contact with an obstacle (the plant's, and the controller's impact law: controller.impact)
    contact_time_constant: float  # s, critically damped
    contact_impedance: float  # 1, the contact's largest impedance d_max
    contact_weight: float  # 1/kg, the tip link's inverse inertia that scales the contact's softness

    @property
    def n_joints(self) -> int:
        return len(self.links)


@dataclass(frozen=True)
class UVMSParams:
    """A whole vehicle: hull, thrusters and one arm variant."""

    name: str
    source: Path
    hull: Hull
    thrusters: tuple[Thruster, ...]
    arm: Arm

    @property
    def n_joints(self) -> int:
        return self.arm.n_joints

    @property
    def n_thrusters(self) -> int:
        return len(self.thrusters)

    @property
    def n_inputs(self) -> int:
        """Length of u = [thruster forces (N), joint torques (N m)]."""
        return self.n_thrusters + self.n_joints

    @property
    def n_states(self) -> int:
        """Length of the paper's state h = [x y z phi theta psi q_m | v omega qdot_m]."""
        return 2 * (6 + self.n_joints)

    def input_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of u."""
        lo = [t.force_range[0] for t in self.thrusters] + [-lk.torque_limit for lk in self.arm.links]
        hi = [t.force_range[1] for t in self.thrusters] + [lk.torque_limit for lk in self.arm.links]
        return np.array(lo), np.array(hi)

    def allocation_matrix(self) -> np.ndarray:
        """(6, n_thrusters): body-frame wrench [N, N m] about the hull origin per newton of thrust."""
        cols = [np.concatenate([t.direction, np.cross(t.position, t.direction)]) for t in self.thrusters]
        return np.column_stack(cols)

    def max_thrust_along(self, direction: np.ndarray, lo: np.ndarray | None = None,
                         hi: np.ndarray | None = None) -> float:
        """The largest total thruster force [N] along a body-frame unit direction, each thruster within
        its bounds lo, hi [N] (default: `input_bounds`; 0 and 0 for a dead one)."""
        b_lo, b_hi = self.input_bounds()
        lo = b_lo if lo is None else lo
        hi = b_hi if hi is None else hi
        nt = self.n_thrusters
        along = self.allocation_matrix()[:3].T @ np.asarray(direction, float)
        return float(np.sum(np.maximum(along * lo[:nt], along * hi[:nt])))

    def weight_in_water(self, density: float, gravity: float) -> float:
        """The whole vehicle's weight less its buoyancy [N] (positive: it sinks): sum of (m_i - rho V_i) g
        over the hull (its trim folded in) and the links; density [kg/m^3], gravity [m/s^2]."""
        parts = [(self.hull.mass, self.hull.volume)] + [(lk.mass, lk.volume) for lk in self.arm.links]
        return float(sum(m - density * v for m, v in parts) * gravity)

    def without_arm(self) -> UVMSParams:
        """The hull alone (zero links): for hull-only experiments."""
        arm = Arm(name="none", links=(), home=_frozen([]), stowed=_frozen([]), end_effector=_frozen([0, 0, 0]),
                  tip_radius=self.arm.tip_radius, tip_force_limit=self.arm.tip_force_limit,
                  contact_time_constant=self.arm.contact_time_constant, contact_impedance=self.arm.contact_impedance,
                  contact_weight=self.arm.contact_weight)
        return replace(self, arm=arm)


# --------------------------------------------------------------------------------------------
# Validation machinery: a table reader that knows its file and dotted path.


@dataclass
class _Table:
    data: dict[str, Any]
    file: Path
    path: str
    used: set[str] = field(default_factory=set)

    def _where(self, key: str) -> str:
        return f"{self.file.name}: {self.path + '.' if self.path else ''}{key}"

    def fail(self, key: str, msg: str) -> ParamError:
        return ParamError(f"{self._where(key)}: {msg}")

    def _get(self, key: str) -> Any:
        if key not in self.data:
            raise self.fail(key, "missing key")
        self.used.add(key)
        return self.data[key]

    def table(self, key: str) -> _Table:
        v = self._get(key)
        if not isinstance(v, dict):
            raise self.fail(key, f"expected a table, got {type(v).__name__}")
        return _Table(v, self.file, f"{self.path + '.' if self.path else ''}{key}")

    def tables(self, key: str) -> list[_Table]:
        v = self._get(key)
        if not isinstance(v, list) or not all(isinstance(t, dict) for t in v) or not v:
            raise self.fail(key, "expected a non-empty array of tables ([[...]])")
        return [_Table(t, self.file, f"{self.path}.{key}[{i}]".lstrip(".")) for i, t in enumerate(v)]

    def string(self, key: str, allowed: tuple[str, ...] | None = None) -> str:
        v = self._get(key)
        if not isinstance(v, str) or not v:
            raise self.fail(key, "expected a non-empty string")
        if allowed is not None and v not in allowed:
            raise self.fail(key, f"{v!r} is not allowed; allowed: {', '.join(allowed)}")
        return v

    def strings(self, key: str) -> list[str]:
        v = self._get(key)
        if not isinstance(v, list) or not v or not all(isinstance(s, str) for s in v):
            raise self.fail(key, "expected a non-empty list of strings")
        return v

    def quantity(
        self,
        key: str,
        unit: str,
        shape: tuple[int, ...] = (),
        *,
        min_value: float | None = None,
        strict_min: bool = False,
        max_value: float | None = None,
    ) -> np.ndarray:
        """A number or array written as {value, unit, source}; checked for unit, shape, range."""
        q = self._get(key)
        if not isinstance(q, dict) or set(q) != {"value", "unit", "source"}:
            raise self.fail(key, 'expected { value = ..., unit = "...", source = "..." }')
        if q["unit"] != unit:
            raise self.fail(key, f"unit {q['unit']!r} is not allowed; allowed: {unit!r}")
        if not isinstance(q["source"], str) or not q["source"].strip():
            raise self.fail(key, "source must be a non-empty string")
        try:
            arr = np.array(q["value"], dtype=float)
        except (TypeError, ValueError):
            raise self.fail(key, "value must be a number or a rectangular array of numbers") from None
        if arr.shape != shape:
            raise self.fail(key, f"shape {arr.shape} is not allowed; allowed: {shape}")
        if not np.all(np.isfinite(arr)):
            raise self.fail(key, "value must be finite")
        if min_value is not None:
            bad = arr <= min_value if strict_min else arr < min_value
            if np.any(bad):
                op = ">" if strict_min else ">="
                raise self.fail(key, f"value {arr.tolist()} out of range; allowed: {op} {min_value}")
        if max_value is not None and np.any(arr > max_value):
            raise self.fail(key, f"value {arr.tolist()} out of range; allowed: <= {max_value}")
        return _frozen(arr)

    def scalar(self, key: str, unit: str, **kw: Any) -> float:
        return float(self.quantity(key, unit, (), **kw))

    def unit_vector(self, key: str) -> np.ndarray:
        v = self.quantity(key, "1", (3,))
        if abs(np.linalg.norm(v) - 1.0) > 1e-6:
            raise self.fail(key, f"norm {np.linalg.norm(v):.6g} is not allowed; "
                                 "allowed: a unit vector (|n| = 1 within 1e-6)")
        return v

    def finish(self) -> None:
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            raise self.fail(unknown[0], f"unknown key; allowed: {', '.join(sorted(self.used))}")


def _superellipsoid(t: _Table) -> Superellipsoid:
    semi = t.quantity("semi_axes", "m", (3,), min_value=0.0, strict_min=True)
    eps = t.quantity("exponents", "1", (2,), min_value=0.0, strict_min=True, max_value=2.0)
    t.finish()
    return Superellipsoid(semi_axes=semi, eps1=float(eps[0]), eps2=float(eps[1]))


def _six(t: _Table, unit_lin: str, unit_rot: str) -> np.ndarray:
    lin = t.quantity("translational", unit_lin, (3,), min_value=0.0)
    rot = t.quantity("rotational", unit_rot, (3,), min_value=0.0)
    t.finish()
    return _frozen(np.concatenate([lin, rot]))


def _trim(t: _Table) -> TrimMass:
    item = TrimMass(name=t.string("name"), mass=t.scalar("mass", "kg", min_value=0.0),
                    volume=t.scalar("volume", "m^3", min_value=0.0), position=t.quantity("position", "m", (3,)))
    t.finish()
    return item


def parallel_axis(r: np.ndarray) -> np.ndarray:
    """|r|^2 I - r r^T: inertia of a unit point mass at r about the origin."""
    return float(r @ r) * np.eye(3) - np.outer(r, r)


def _hull(t: _Table, with_trim: bool) -> Hull:
    mass = t.scalar("mass", "kg", min_value=0.0, strict_min=True)
    inertia = t.quantity("inertia", "kg*m^2", (3,), min_value=0.0, strict_min=True)
    com = t.quantity("com", "m", (3,))
    volume = t.scalar("volume", "m^3", min_value=0.0, strict_min=True)
    cob = t.quantity("cob", "m", (3,))
    trim = tuple(_trim(x) for x in t.tables("trim")) if "trim" in t.data else ()
    trim = trim if with_trim else ()
    # Fold the trim point masses into one rigid body.
    m_tot = mass + sum(x.mass for x in trim)
    c_tot = (mass * com + sum(x.mass * x.position for x in trim)) / m_tot
    inertia_tot = np.diag(inertia) + mass * parallel_axis(com - c_tot) + sum(
        (x.mass * parallel_axis(x.position - c_tot) for x in trim), np.zeros((3, 3)))
    v_tot = volume + sum(x.volume for x in trim)
    b_tot = (volume * cob + sum(x.volume * x.position for x in trim)) / v_tot
    hull = Hull(
        mass=m_tot, inertia=_frozen(inertia_tot), com=_frozen(c_tot), volume=v_tot, cob=_frozen(b_tot),
        size=t.quantity("size", "m", (3,), min_value=0.0, strict_min=True),
        arm_mount=t.quantity("arm_mount", "m", (3,)),
        superellipsoid=_superellipsoid(t.table("superellipsoid")),
        added_mass=_six(t.table("added_mass"), "kg", "kg*m^2"),
        linear_damping=_six(t.table("linear_damping"), "N*s/m", "N*m*s/rad"),
        quadratic_damping=_six(t.table("quadratic_damping"), "N*s^2/m^2", "N*m*s^2/rad^2"),
        mujoco_fluidcoef=t.quantity("mujoco_fluidcoef", "1", (5,), min_value=0.0),
        trim=trim,
    )
    t.finish()
    return hull


def _thruster(t: _Table) -> Thruster:
    fr = t.quantity("force_range", "N", (2,))
    if not fr[0] < fr[1]:
        raise t.fail("force_range", f"{fr.tolist()} is not allowed; allowed: [min, max] with min < max")
    th = Thruster(name=t.string("name"), position=t.quantity("position", "m", (3,)),
                  direction=t.unit_vector("direction"), force_range=fr)
    t.finish()
    return th


def _link(name: str, t: _Table) -> Link:
    rng = t.quantity("joint_range", "rad", (2,))
    if not rng[0] < rng[1]:
        raise t.fail("joint_range", f"{rng.tolist()} is not allowed; allowed: [min, max] with min < max")
    link = Link(
        name=name,
        joint_axis=t.unit_vector("joint_axis"),
        joint_range=rng,
        torque_limit=t.scalar("torque_limit", "N*m", min_value=0.0, strict_min=True),
        rotor_inertia=t.scalar("rotor_inertia", "kg*m^2", min_value=0.0),
        joint_damping=t.scalar("joint_damping", "N*m*s/rad", min_value=0.0),
        length=t.scalar("length", "m", min_value=0.0, strict_min=True),
        radius=t.scalar("radius", "m", min_value=0.0, strict_min=True),
        mass=t.scalar("mass", "kg", min_value=0.0, strict_min=True),
        com=t.quantity("com", "m", (3,)),
        inertia=t.quantity("inertia", "kg*m^2", (3,), min_value=0.0, strict_min=True),
        volume=t.scalar("volume", "m^3", min_value=0.0, strict_min=True),
        cob=t.quantity("cob", "m", (3,)),
        superellipsoid=_superellipsoid(t.table("superellipsoid")),
        added_mass_coefficient=t.scalar("added_mass_coefficient", "1", min_value=0.0),
        drag_coefficient=t.scalar("drag_coefficient", "1", min_value=0.0),
        mujoco_fluidcoef=t.quantity("mujoco_fluidcoef", "1", (5,), min_value=0.0),
    )
    t.finish()
    return link


def _arm(name: str, t: _Table, links: dict[str, Link]) -> Arm:
    names = t.strings("links")
    for n in names:
        if n not in links:
            raise t.fail("links", f"unknown link {n!r}; allowed: {', '.join(links)}")
    n = len(names)
    chain = tuple(links[k] for k in names)
    postures = {key: t.quantity(key, "rad", (n,)) for key in ("home", "stowed")}
    for key, q in postures.items():
        for i, (lk, qi) in enumerate(zip(chain, q, strict=True)):
            if not lk.joint_range[0] <= qi <= lk.joint_range[1]:
                raise t.fail(key, f"joint {i} ({lk.name}) at {qi} rad is outside its range "
                                  f"{lk.joint_range.tolist()}; allowed: within the joint range")
    home = postures["home"]
    arm = Arm(name=name, links=chain, home=home, stowed=postures["stowed"],
              end_effector=t.quantity("end_effector", "m", (3,)),
              tip_radius=t.scalar("tip_radius", "m", min_value=0.0, strict_min=True),
              tip_force_limit=t.scalar("tip_force_limit", "N", min_value=0.0, strict_min=True),
              contact_time_constant=t.scalar("contact_time_constant", "s", min_value=0.0, strict_min=True),
              contact_impedance=t.scalar("contact_impedance", "1", min_value=0.0, strict_min=True, max_value=1.0),
              contact_weight=t.scalar("contact_weight", "1/kg", min_value=0.0, strict_min=True))
    t.finish()
    return arm


def read_table(path: Path, kind: str, schema: str) -> _Table:
    """The top table of a TOML file of the given schema, or a one-line ParamError."""
    try:
        raw = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ParamError(f"{path}: no such {kind} file") from None
    except tomllib.TOMLDecodeError as e:
        raise ParamError(f"{path.name}: not valid TOML: {e}") from None
    top = _Table(raw, path, "")
    top.string("schema", (schema,))
    return top


def load_params(path: str | Path = DEFAULT_VEHICLE, arm: str | None = None, trim: bool = True) -> UVMSParams:
    """Load and validate a vehicle file; `arm` picks an arm variant (default: the file's own);
    `trim=False` leaves out the hull's trim elements (the bare literature hull).

    Raises:
        ParamError: one line naming the file, the field and what is allowed.
    """
    path = Path(path)
    top = read_table(path, "vehicle", VEHICLE_SCHEMA)
    name = top.string("name")
    default_arm = top.string("default_arm")
    hull = _hull(top.table("hull"), trim)
    thrusters = tuple(_thruster(t) for t in top.tables("thrusters"))
    if len({t.name for t in thrusters}) != len(thrusters):
        raise top.fail("thrusters", "thruster names must be unique")
    links_t = top.table("links")
    links = {k: _link(k, links_t.table(k)) for k in list(links_t.data)}
    arms_t = top.table("arms")
    arms = {k: _arm(k, arms_t.table(k), links) for k in list(arms_t.data)}
    top.finish()
    choice = arm or default_arm
    if choice not in arms:
        raise ParamError(f"{path.name}: arm {choice!r} is not defined; allowed: {', '.join(arms)}")
    return UVMSParams(name=name, source=path, hull=hull, thrusters=thrusters, arm=arms[choice])


def arm_variants(path: str | Path = DEFAULT_VEHICLE) -> tuple[str, ...]:
    """Names of the arm variants a vehicle file defines."""
    return tuple(tomllib.loads(Path(path).read_text())["arms"])
