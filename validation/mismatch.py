"""Declared, seeded model mismatch between the controller's parameters and the plant's.

A mismatch is written as terms separated by spaces, each `name OP distribution`:
    added_mass*U(0.8,1.2)   scale the plant's added mass (hull and links)
    drag*U(0.8,1.2)         scale the plant's fluid-force coefficients (hull and links)
    mass*U(0.97,1.03)       scale the plant's hull mass and inertia (its volume is kept)
    mass_weight*U(0.8,1.3)  only the weight in water of `mass`: the hull's displaced volume less by
                            (k - 1) m / rho, its mass and inertia kept
    mass_inertia*U(0.8,1.3) only the inertia of `mass`: mass and inertia scaled, the displaced
                            volume more by (k - 1) m / rho, so its weight in water is kept
    cob+U(-0.003,0.003)     shift the plant's hull centre of buoyancy along body z [m]
    current+U(-0.1,0.1)     add an unknown current along world x [m/s] to the plant's
    friction*U(0.6,1.4)     scale the obstacles' contact friction
    friction_coefficient=U(0.1,0.8)  set every obstacle's contact friction coefficient [-]
    trim+U(-2,2)            the error of the trim check that tells the controller the vehicle's weight
                            in water before the run [N] (controller.protocol.Task.trim)
    thruster=U(0,8)         one thruster, floor of the draw, dead from t = 0 without the controller
                            knowing
with distributions U(a,b) (uniform), N(mean,std) (normal) or a plain number. The draw is seeded; the
drawn values and the spec are recorded in the run's summary. The controller always keeps the
parameter file's values: every difference is this declared mismatch.

Named specs (`NAMED`, the command line's `--mismatch NAME`): "default", the parameter file's
uncertainty as a well-identified vehicle has it; "wide", a vehicle known only roughly (hull mass
-20 to +30 % with its volume kept, so it is up to 4 kg heavy or 2.7 kg light in water; added mass
and drag +-30 %; a wall friction coefficient anywhere from 0.1 to 0.8; an unknown current of up to
0.2 m/s along world x, towards or away from the wall); "none". Both named uncertain specs tell the
controller the vehicle's weight in water to within 2 N, as a trim check before a dive does.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from uvms.params import UVMSParams
from uvms.scene import Scene

DEFAULT = "added_mass*U(0.8,1.2) drag*U(0.8,1.2) mass*U(0.97,1.03) cob+U(-0.003,0.003) friction*U(0.6,1.4) trim+U(-2,2)"
NONE = ""
WIDE = ("added_mass*U(0.7,1.3) drag*U(0.7,1.3) mass*U(0.8,1.3) cob+U(-0.003,0.003) friction_coefficient=U(0.1,0.8) "
        "current+U(-0.2,0.2) trim+U(-2,2)")
NAMED = {"default": DEFAULT, "wide": WIDE, "none": NONE}
_OPS = {"added_mass": "*", "drag": "*", "mass": "*", "mass_weight": "*", "mass_inertia": "*", "cob": "+",
        "current": "+", "trim": "+", "friction": "*", "friction_coefficient": "=", "thruster": "="}
_TERM = re.compile(r"^(?P<name>[a-z_]+)(?P<op>[*+=])(?P<dist>.+)$")
_DIST = re.compile(r"^(?:(?P<kind>[UN])\((?P<a>[-+0-9.eE]+),(?P<b>[-+0-9.eE]+)\)|(?P<value>[-+0-9.eE]+))$")


@dataclass(frozen=True)
class Term:
    name: str
    op: str
    kind: str  # "U", "N" or "const"
    a: float
    b: float

    def draw(self, rng: np.random.Generator) -> float:
        if self.kind == "U":
            return float(rng.uniform(self.a, self.b))
        if self.kind == "N":
            return float(rng.normal(self.a, self.b))
        return self.a


def resolve(text: str) -> str:
    """The spec of a name of NAMED, or the text itself (checked by `parse`: one line if bad)."""
    spec = NAMED.get(text, text)
    parse(spec)
    return spec


def parse(spec: str) -> tuple[Term, ...]:
    """The terms of a mismatch spec, or a one-line ValueError naming the bad term."""
    terms = []
    for text in spec.replace(";", " ").split():
        m = _TERM.match(text)
        d = _DIST.match(m.group("dist")) if m else None
        if not m or not d:
            raise ValueError(f"mismatch term {text!r} is malformed; allowed: {', '.join(NAMED)}, or terms "
                             f"name*U(a,b), name+N(mean,std) or name*number with name one of {', '.join(_OPS)}")
        name, op = m.group("name"), m.group("op")
        if name not in _OPS:
            raise ValueError(f"unknown mismatch {name!r}; allowed: {', '.join(_OPS)}")
        if op != _OPS[name]:
            raise ValueError(f"mismatch {name!r} takes {_OPS[name]!r}, not {op!r}; allowed: {name}{_OPS[name]}...")
        if d.group("kind"):
            terms.append(Term(name, op, d.group("kind"), float(d.group("a")), float(d.group("b"))))
        else:
            terms.append(Term(name, op, "const", float(d.group("value")), 0.0))
    return tuple(terms)


def draw(spec: str, seed: int) -> dict[str, float]:
    """The seeded values of every term (name -> value)."""
    rng = np.random.default_rng(seed)
    return {t.name: t.draw(rng) for t in parse(spec)}


def apply(params: UVMSParams, scene: Scene,
          values: dict[str, float]) -> tuple[UVMSParams, Scene, np.ndarray, list[int]]:
    """The plant's parameters and scene under the drawn values, the unknown extra current [m/s]
    and the unknown dead thrusters."""
    hull, links = params.hull, list(params.arm.links)
    if "added_mass" in values:
        k = values["added_mass"]
        hull = replace(hull, added_mass=hull.added_mass * k)
        links = [replace(lk, added_mass_coefficient=lk.added_mass_coefficient * k) for lk in links]
    if "drag" in values:
        k = values["drag"]
        hull = replace(hull, mujoco_fluidcoef=_scale_fluid(hull.mujoco_fluidcoef, k),
                       linear_damping=hull.linear_damping * k, quadratic_damping=hull.quadratic_damping * k)
        links = [replace(lk, mujoco_fluidcoef=_scale_fluid(lk.mujoco_fluidcoef, k),
                         drag_coefficient=lk.drag_coefficient * k) for lk in links]
    extra_volume = hull.mass / scene.water.density  # m^3 per unit of k - 1: the hull's mass as displaced water
    if "mass_weight" in values:
        hull = replace(hull, volume=hull.volume - (values["mass_weight"] - 1.0) * extra_volume)
    if "mass_inertia" in values:
        k = values["mass_inertia"]
        hull = replace(hull, mass=hull.mass * k, inertia=hull.inertia * k,
                       volume=hull.volume + (k - 1.0) * extra_volume)
    if "mass" in values:
        k = values["mass"]
        hull = replace(hull, mass=hull.mass * k, inertia=hull.inertia * k)
    if "cob" in values:
        hull = replace(hull, cob=hull.cob + np.array([0.0, 0.0, values["cob"]]))
    plant = replace(params, hull=hull, arm=replace(params.arm, links=tuple(links)))
    if "friction" in values:
        scene = scene.with_planes(tuple(replace(p, friction=p.friction * values["friction"]) for p in scene.planes))
    if "friction_coefficient" in values:
        mu = max(0.0, values["friction_coefficient"])
        scene = scene.with_planes(tuple(replace(p, friction=mu) for p in scene.planes))
    current = np.array([values.get("current", 0.0), 0.0, 0.0])
    dead = [int(np.clip(np.floor(values["thruster"]), 0, params.n_thrusters - 1))] if "thruster" in values else []
    return plant, scene, current, dead


def _scale_fluid(coef: np.ndarray, k: float) -> np.ndarray:
    """MuJoCo's [blunt, slender, angular, Kutta, Magnus]: the drag terms scaled, lift terms kept."""
    out = np.array(coef, float)
    out[:3] *= k
    return out
