"""Plant speed: physics steps and control periods per second, default vehicle with one wall.

Run: `python bench/plant_speed.py` (or `make bench`). Writes bench/results/plant_speed.json and
.md. Medians over repeats, all variants measured side by side in one run (the machine is shared).
`--before REV` also measures the plant of git revision REV (its uvms_mj/ checked out into a temp
dir; the rest of the tree is this one's) and writes both side by side: each plant runs in its own
subprocess, the two alternating for `ROUNDS` rounds, and each figure is the median over rounds.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

import uvms_mj
from uvms import load_params, load_scene
from uvms_mj.build import BuildOptions
from uvms_mj.plant import Plant, PlantSettings

CONTROL_PERIOD = 0.1  # s
PERIODS = 20  # per repeat: 2 s of simulated time
REPEATS = 7
ROUNDS = 3  # with --before: alternating subprocess runs of each plant
OUT = Path(__file__).parent / "results"
ROOT = Path(__file__).resolve().parent.parent


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


def _figures(seconds: float, steps: int) -> dict[str, float]:
    """Rates from the median seconds per control period of `steps` physics steps."""
    return {"ms_per_control_period": 1e3 * seconds, "control_periods_per_s": 1 / seconds,
            "physics_steps_per_s": steps / seconds, "real_time_factor": CONTROL_PERIOD / seconds}


def _measure(rev: str | None) -> dict[str, dict[str, float]]:
    """This benchmark's figures in a subprocess, for the uvms_mj/ of git revision `rev` (None: this tree)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = [str(ROOT)]
        if rev is not None:
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", rev, "uvms_mj"],
                                     check=True, capture_output=True).stdout
            (Path(tmp) / "src.tar").write_bytes(archive)
            with tarfile.open(Path(tmp) / "src.tar") as tar:
                tar.extractall(tmp, filter="data")
            path.insert(0, tmp)
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(path)}
        out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--json-only"], env=env, cwd=tmp,
                             check=True, capture_output=True, text=True).stdout
    got = json.loads(out.strip().splitlines()[-1])
    expected = Path(tmp) / "uvms_mj" if rev is not None else ROOT / "uvms_mj"
    if Path(got["uvms_mj"]) != expected:
        raise RuntimeError(f"measured {got['uvms_mj']}, not {expected}")
    return got["variants"]


def _compare(rev: str) -> dict[str, dict[str, dict[str, float]]]:
    """Figures of revision `rev`'s plant and of this tree's, alternating, medians over ROUNDS."""
    rounds: dict[str, list] = {f"before ({rev})": [], "this tree": []}
    for _ in range(ROUNDS):
        rounds[f"before ({rev})"].append(_measure(rev))
        rounds["this tree"].append(_measure(None))
    return {run: {k: {f: statistics.median(r[k][f] for r in rs) for f in rs[0][k]} for k in rs[0]}
            for run, rs in rounds.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--before", metavar="REV", help="also measure the plant (uvms_mj/) of this git revision")
    ap.add_argument("--json-only", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    plant = _plant()
    steps = round(CONTROL_PERIOD / plant.model.opt.timestep)
    rows = {"plant": time_plant(True), "plant, added mass off": time_plant(False),
            "bare mj_step": time_raw_mj_step()}
    variants = {k: _figures(v, steps) for k, v in rows.items()}
    if args.json_only:
        print(json.dumps({"uvms_mj": str(Path(uvms_mj.__file__).parent), "variants": variants}))
        return
    runs = {"this tree": variants}
    if args.before:
        runs = _compare(args.before)
    result = {
        "machine": {"python": platform.python_version(), "mujoco": mujoco.__version__,
                    "processor": platform.processor() or platform.machine(), "cpus": __import__("os").cpu_count()},
        "timestep_s": plant.model.opt.timestep, "control_period_s": CONTROL_PERIOD, "repeats": REPEATS,
        "command": " ".join(["python", "bench/plant_speed.py", *sys.argv[1:]]),
        "runs": runs,
    }
    OUT.mkdir(exist_ok=True)
    (OUT / "plant_speed.json").write_text(json.dumps(result, indent=2))
    lines = [f"# Plant speed ({result['machine']['processor']}, {result['machine']['cpus']} CPUs, "
             f"mujoco {mujoco.__version__})", "",
             f"Default vehicle (alpha4) with one wall, timestep {plant.model.opt.timestep * 1e3:g} ms, control period "
             f"{CONTROL_PERIOD * 1e3:g} ms, median of {REPEATS} repeats of {PERIODS} periods"
             + (f" (with --before: median over {ROUNDS} alternating subprocess runs of each plant)." if args.before
                else "."), "",
             f"Command: `{result['command']}`.", "",
             "| plant | variant | ms / control period | control periods / s | physics steps / s | real-time factor |",
             "|---|---|---|---|---|---|"]
    for run, variants in runs.items():
        for k, v in variants.items():
            lines.append(f"| {run} | {k} | {v['ms_per_control_period']:.2f} | {v['control_periods_per_s']:.0f} | "
                         f"{v['physics_steps_per_s']:.0f} | {v['real_time_factor']:.1f} |")
    (OUT / "plant_speed.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    from validation import manifest

    with manifest.recorded(Path(__file__).parent / "results" / "plant_speed.manifest.json"):
        main()
