"""A registry of small declarative closed-loop scenarios (issue 5): wall approaches in the default
scene (wall x = 2 m with its normal along -x, seafloor z = -3 m).

Every approach starts at rest in attitude with the hull's front `gap` m from the wall, moving at
`speed` m/s at `angle` deg to the wall's normal, at depth `depth`; the task is to rest with the front
`target_gap` m from the wall at the start's depth and heading. `failed_thrusters` die at `fail_at`
seconds (in the plant; the controller is told at once, as in the paper's thruster-malfunction
case). The BlueROV2's drag is large (141 N s^2/m^2 in surge): with its thrusters it brakes 0.9 m/s
within 5 cm, and without them it still coasts from 1.3 m/s to rest within 0.16 m in MuJoCo. So the
unavoidable approaches here combine lost thrust with a current that keeps pushing, as in the
paper's Case 4B.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

HORIZONTAL = (0, 1, 2, 3)
ALL = tuple(range(8))


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    gap: float = 1.0  # m, hull front to the wall
    speed: float = 0.3  # m/s
    angle: float = 0.0  # deg between the velocity and the wall's inward normal (in the horizontal plane)
    depth: float = -1.5  # m
    sink: float = 0.0  # m/s, downward speed at the start
    posture: str = "stowed"  # the arm's start: "stowed" or "home"
    target_gap: float = 1.0  # m
    current: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m/s, world, from t = 0
    gust: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m/s added linearly from 1 s to 2 s, then held
    failed_thrusters: tuple[int, ...] = ()
    fail_at: float = 0.0  # s
    duration: float = 4.0  # s
    arm: str = "alpha4"

    def with_overrides(self, overrides: dict[str, str]) -> Scenario:
        """A copy with `key=value` overrides (numbers, tuples as comma-separated numbers)."""
        known = {f.name: f for f in fields(self)}
        changes = {}
        for key, text in overrides.items():
            if key not in known or key in ("name", "description"):
                allowed = ", ".join(k for k in known if k not in ("name", "description"))
                raise ValueError(f"unknown setting {key!r}; allowed: {allowed}")
            current = getattr(self, key)
            try:
                if isinstance(current, tuple):
                    kind = int if key == "failed_thrusters" else float
                    changes[key] = tuple(kind(v) for v in text.split(",") if v.strip())
                elif isinstance(current, str):
                    changes[key] = text
                else:
                    changes[key] = type(current)(text)
            except ValueError:
                raise ValueError(f"setting {key}={text!r} is malformed; allowed: a value like "
                                 f"{current!r}") from None
        return replace(self, **changes)


SCENARIOS: dict[str, Scenario] = {s.name: s for s in (
    Scenario("avoid-wall", "0.3 m/s towards the wall 1 m ahead, thrusters working: Mode I only"),
    Scenario("wall-headon", "1.2 m/s head-on, 0.4 m from the wall, 0.25 m/s current towards it, horizontal "
             "thrusters lost at t = 0", gap=0.4, speed=1.2, current=(0.25, 0.0, 0.0), failed_thrusters=HORIZONTAL,
             duration=5.0),
    Scenario("wall-oblique", "as wall-headon, moving at 30 deg to the wall's normal", gap=0.4, speed=1.2, angle=30.0,
             current=(0.25, 0.0, 0.0), failed_thrusters=HORIZONTAL, duration=5.0),
    Scenario("arm-deployed", "as wall-headon, the arm starting at home (deployed forward)", gap=0.4, speed=1.2,
             posture="home", current=(0.25, 0.0, 0.0), failed_thrusters=HORIZONTAL, duration=5.0),
    Scenario("current-steady", "station keeping 0.4 m from the wall in a 0.3 m/s current towards it",
             gap=0.4, speed=0.0, target_gap=0.4, current=(0.3, 0.0, 0.0), duration=4.0),
    Scenario("current-gust", "station keeping 0.4 m from the wall, current rising from 0.1 to 0.4 m/s at 1-2 s",
             gap=0.4, speed=0.0, target_gap=0.4, current=(0.1, 0.0, 0.0), gust=(0.3, 0.0, 0.0), duration=4.0),
    Scenario("thrusters-dead", "every thruster dead at t = 0, drifting at 0.4 m/s in a 0.25 m/s current towards "
             "the wall 0.6 m ahead (Case 4B)", gap=0.6, speed=0.4, current=(0.25, 0.0, 0.0), failed_thrusters=ALL,
             duration=5.0),
    Scenario("corner", "0.5 m/s towards the wall 0.5 m ahead, 0.3 m above the seafloor, sinking 0.2 m/s",
             gap=0.5, speed=0.5, depth=-2.45, sink=0.2, duration=3.0),
    Scenario("mission-near-wall", "hold a point 0.3 m from the wall; all thrusters fail at 1 s in a 0.15 m/s "
             "current towards the wall", gap=0.3, speed=0.0, target_gap=0.3, current=(0.15, 0.0, 0.0),
             failed_thrusters=ALL, fail_at=1.0, duration=4.0),
)}


def get(name: str) -> Scenario:
    if name not in SCENARIOS:
        raise ValueError(f"unknown scenario {name!r}; allowed: {', '.join(SCENARIOS)}")
    return SCENARIOS[name]
