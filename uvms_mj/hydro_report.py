"""Terminal speeds of the plant's hull under constant thrust, against the Fossen damping of the
parameter file. The two differ on purpose (the plant's drag is MuJoCo's ellipsoid model, not the
paper's): `python -m uvms_mj.hydro_report` prints the table the README quotes."""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass

import numpy as np

from uvms import load_params, load_scene
from uvms.params import UVMSParams
from uvms.scene import Scene
from uvms_mj.plant import Plant

AXES = ("surge", "sway", "heave", "roll", "pitch", "yaw")
# Axis index and body wrench [N or N m]: the rotational axes with restoring moments (roll, pitch)
# reach an angle, not a speed, and are left out.
DEFAULT_CASES = ((0, 20.0), (1, 20.0), (2, 20.0), (5, 2.0))


@dataclass(frozen=True)
class TerminalSpeed:
    """Steady speed [m/s or rad/s] along one body axis under a constant body wrench."""

    axis: str
    wrench: float
    mujoco: float
    fossen: float

    @property
    def ratio(self) -> float:
        return self.mujoco / self.fossen


def fossen_terminal_speed(linear: float, quadratic: float, force: float) -> float:
    """Speed where d_l v + d_q v|v| = F (F > 0)."""
    if quadratic == 0:
        return force / linear
    return (-linear + np.sqrt(linear**2 + 4 * quadratic * force)) / (2 * quadratic)


def terminal_speeds(params: UVMSParams, scene: Scene, duration: float = 30.0,
                    cases: tuple[tuple[int, float], ...] = DEFAULT_CASES) -> list[TerminalSpeed]:
    """Hull alone, neutrally buoyant, open water: thrust allocated for a pure body wrench."""
    p = params.without_arm()
    p = dataclasses.replace(p, hull=dataclasses.replace(p.hull, volume=p.hull.mass / scene.water.density))
    water = scene.with_planes(())
    pinv = np.linalg.pinv(p.allocation_matrix())
    out = []
    for axis, amount in cases:
        w = np.zeros(6)
        w[axis] = amount
        u = pinv @ w
        plant = Plant(p, water)
        r = plant.step(u, duration)
        speed = float(r.h[6 + axis])
        H = p.hull
        out.append(TerminalSpeed(AXES[axis], amount, speed,
                                 fossen_terminal_speed(H.linear_damping[axis], H.quadratic_damping[axis], amount)))
    return out


def markdown(rows: list[TerminalSpeed]) -> str:
    lines = ["| axis | body wrench | MuJoCo plant | Fossen (parameter file) | ratio |",
             "|---|---|---|---|---|"]
    for r in rows:
        unit, sunit = ("N", "m/s") if r.axis in AXES[:3] else ("N m", "rad/s")
        lines.append(f"| {r.axis} | {r.wrench:g} {unit} | {r.mujoco:.3f} {sunit} | {r.fossen:.3f} {sunit} "
                     f"| {r.ratio:.2f} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=30.0, help="simulated seconds per axis")
    args = ap.parse_args()
    print(markdown(terminal_speeds(load_params(), load_scene(), args.duration)))


if __name__ == "__main__":
    main()
