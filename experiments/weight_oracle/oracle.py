"""The default switching NMPC told the drawn truth in its observer's slot: the extra current and the
hull's extra weight in water of the run's mismatch draw, from the first step and through every
contact (the ceiling of any observer of those two).

PYTHONPATH=. MUJOCO_GL=egl python experiments/weight_oracle/oracle.py OUT SCEN:SEED [SCEN:SEED ...]
    [--mismatch wide] [--workers 2]
writes OUT/results.csv (one row per run: the oracle's verdict, reason, smallest hull distance,
tip peak) and OUT/manifest.json.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np
from tqdm import tqdm

from controller.model import water
from controller.switching import SwitchingController, SwitchingSettings
from uvms import load_params, load_scene
from validation import manifest, mismatch
from validation.closed_loop import run
from validation.scenarios import get


class Told:
    """An observer that knows: its estimate is the drawn extra current and extra weight."""

    updates = 1  # told from the start: never planning with the trim check's weight instead

    def __init__(self, current_x: float, weight: float):
        self.estimate = water([current_x, 0.0, 0.0], weight)

    def update(self, *args, **kwargs) -> np.ndarray:
        return self.estimate

    def reset(self) -> None:
        """Nothing to forget: the truth stays told."""


class Oracle(SwitchingController):
    """The default controller whose observer is `Told` the truth."""

    def __init__(self, current_x: float, weight: float):
        super().__init__(SwitchingSettings())
        self.truth = (current_x, weight)

    def reset(self, task) -> None:
        super().reset(task)
        self.observer = Told(*self.truth)


def truth(spec: str, seed: int) -> tuple[float, float]:
    """The drawn extra current along world x [m/s] and extra hull weight in water [N]."""
    drawn = mismatch.draw(mismatch.resolve(spec), seed)
    params, scene = load_params(), load_scene()
    return drawn.get("current", 0.0), (drawn.get("mass", 1.0) - 1.0) * params.hull.mass * scene.water.gravity


def one(job: tuple[str, int, str]) -> dict:
    scenario, seed, spec = job
    c, w = truth(spec, seed)
    try:
        s = run(get(scenario), controller=Oracle(c, w), mismatch=mismatch.resolve(spec), seed=seed)
        return {"scenario": scenario, "seed": seed, "told_current": c, "told_weight": w, "verdict": s.verdict,
                "min_hull_distance": s.min_hull_distance, "ee_peak_contact_force": s.ee_peak_contact_force,
                "reason": s.reason}
    except Exception as exc:  # a failed run is a row, never the end of the probe
        return {"scenario": scenario, "seed": seed, "told_current": c, "told_weight": w, "verdict": "error",
                "min_hull_distance": float("nan"), "ee_peak_contact_force": float("nan"), "reason": repr(exc)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out", type=Path)
    ap.add_argument("runs", nargs="+", help="SCENARIO:SEED")
    ap.add_argument("--mismatch", default="wide")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    jobs = [(r.split(":")[0], int(r.split(":")[1]), a.mismatch) for r in a.runs]
    a.out.mkdir(parents=True, exist_ok=True)
    started, rows, stamp = time.time(), [], manifest.start()
    with ProcessPoolExecutor(a.workers) as pool:
        for fut in tqdm(as_completed([pool.submit(one, j) for j in jobs]), total=len(jobs)):
            rows.append(fut.result())
    rows.sort(key=lambda r: (r["scenario"], r["seed"]))
    with open(a.out / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    manifest.write(a.out, {"command": "experiments/weight_oracle/oracle.py", "mismatch": a.mismatch,
                           "runs": a.runs, "workers": a.workers}, time.time() - started,
                   command=["python", *sys.argv], started=stamp)


if __name__ == "__main__":
    main()
