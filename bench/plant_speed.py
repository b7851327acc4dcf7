"""Plant speed: physics steps and control periods per second, default vehicle with one wall.

Run: `python bench/plant_speed.py` (or `make bench`). Writes bench/results/plant_speed.json and
.md. Medians over repeats, all variants measured side by side in one run (the machine is shared).
"""

from __future__ import annotations

import json
import platform
import statistics
import time
from pathlib import Path

import mujoco
import numpy as np

from uvms import load_params, load_scene
from uvms_mj.build import BuildOptions
from uvms_mj.plant import Plant, PlantSettings

CONTROL_PERIOD = 0.1  # s
PERIODS = 20  # per repeat: 2 s of simulated time
REPEATS = 7
OUT = Path(__file__).parent / "results"


def _plant(added_mass: bool = True) -> Plant:
    params, scene = load_params(), load_scene()
    wall = tuple(p for p in scene.planes if p.name == "wall")
    return Plant(params, scene.with_planes(wall), PlantSettings(build=BuildOptions(added_mass=added_mass)))


def time_plant(added_mass: bool) -> float:
    """Median seconds per control period (report included)."""
    plant = _plant(added_mass)
    u = np.zeros(plant.params.n_inputs)
    u[:4] = 10.0  # forward: the vehicle reaches the wall within the run
    times = []
    for _ in range(REPEATS):
        plant.reset()
        t0 = time.perf_counter()
        for _ in range(PERIODS):
            plant.step(u, CONTROL_PERIOD)
        times.append((time.perf_counter() - t0) / PERIODS)
    return statistics.median(times)


def time_raw_mj_step() -> float:
    """Median seconds per control period of bare mj_step on the same model (no added-mass
    iteration, no reports): the floor the plant's Python layer is compared with."""
    plant = _plant()
    m, d = plant.model, plant.data
    n = round(CONTROL_PERIOD / m.opt.timestep)
    times = []
    for _ in range(REPEATS):
        mujoco.mj_resetDataKeyframe(m, d, 0)
        d.ctrl[:4] = 10.0
        t0 = time.perf_counter()
        for _ in range(PERIODS * n):
            mujoco.mj_step(m, d)
        times.append((time.perf_counter() - t0) / PERIODS)
    return statistics.median(times)


def main() -> None:
    plant = _plant()
    steps = round(CONTROL_PERIOD / plant.model.opt.timestep)
    rows = {"plant": time_plant(True), "plant, added-mass iteration off": time_plant(False),
            "bare mj_step": time_raw_mj_step()}
    result = {
        "machine": {"python": platform.python_version(), "mujoco": mujoco.__version__,
                    "processor": platform.processor() or platform.machine(), "cpus": __import__("os").cpu_count()},
        "timestep_s": plant.model.opt.timestep, "control_period_s": CONTROL_PERIOD, "repeats": REPEATS,
        "variants": {k: {"ms_per_control_period": 1e3 * v, "control_periods_per_s": 1 / v,
                         "physics_steps_per_s": steps / v, "real_time_factor": CONTROL_PERIOD / v}
                     for k, v in rows.items()},
    }
    OUT.mkdir(exist_ok=True)
    (OUT / "plant_speed.json").write_text(json.dumps(result, indent=2))
    lines = [f"# Plant speed ({result['machine']['processor']}, {result['machine']['cpus']} CPUs, "
             f"mujoco {mujoco.__version__})", "",
             f"Default vehicle (alpha4) with one wall, timestep {plant.model.opt.timestep * 1e3:g} ms, control period "
             f"{CONTROL_PERIOD * 1e3:g} ms, median of {REPEATS} repeats of {PERIODS} periods.", "",
             "| variant | ms / control period | control periods / s | physics steps / s | real-time factor |",
             "|---|---|---|---|---|"]
    for k, v in result["variants"].items():
        lines.append(f"| {k} | {v['ms_per_control_period']:.2f} | {v['control_periods_per_s']:.0f} | "
                     f"{v['physics_steps_per_s']:.0f} | {v['real_time_factor']:.1f} |")
    (OUT / "plant_speed.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
