"""Mode III's recorded problems solved with the hull's attitude in the world's ZYX angles and in angles
relative to a frame pitched by 90 deg (ModelOptions.pitch_offset), side by side: iterations and cost.

  python bench/mode3_solvers.py --record 3 --workers 1 --families thrusters-dead   # the problems
  git apply experiments/mode3_attitude_probe/pitch_offset.diff
  PYTHONPATH=. python experiments/mode3_attitude_probe/replay.py --out DIR

Problems whose hull pitch is at least `--min-pitch` [deg] are solved both ways from the same start
(the recorded guess; its Euler angles re-expressed for the pitched model; the warm multipliers as
recorded). The cost is the same function of the physical motion either way, so a lower iteration
count at the same cost is the parametrization's doing.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
from mode3_solvers import load_problems

from controller.mode3 import ModeIIIOCP, ModeIIISettings
from controller.model import ModelOptions, UVMSModel


def summary(path: Path) -> str:
    """Warm problems by |pitch| band: median and p90 iterations both ways, the paired counts and the
    Wilcoxon signed-rank test, unusable solves, and how often the costs differ by over 10%."""
    from scipy.stats import wilcoxon

    r = list(csv.DictReader(open(path)))
    col = {k: np.array([float(x[k]) if k != "cold" and "usable" not in k else x[k] == "True" for x in r]) for k in r[0]}
    lines = ["| pitch [deg] | problems | iterations, world | iterations, pitched | fewer / more pitched | p "
             "| unusable world / pitched | pitched's cost < 0.9x / > 1.1x |", "|---|---|---|---|---|---|---|---|"]
    for lo, hi in ((0, 45), (45, 75), (75, 91)):
        m = (np.abs(col["pitch_deg"]) >= lo) & (np.abs(col["pitch_deg"]) < hi) & ~col["cold"].astype(bool)
        wi, pi = col["world_iterations"][m], col["pitched_iterations"][m]
        wc, pc = col["world_cost"][m], col["pitched_cost"][m]
        lines.append(f"| {lo}-{hi} | {m.sum()} | {np.median(wi):.0f} (p90 {np.percentile(wi, 90):.0f}) | "
                     f"{np.median(pi):.0f} (p90 {np.percentile(pi, 90):.0f}) | {np.sum(pi < wi)} / {np.sum(pi > wi)} | "
                     f"{wilcoxon(wi, pi).pvalue:.2g} | {np.sum(~col['world_usable'][m].astype(bool))} / "
                     f"{np.sum(~col['pitched_usable'][m].astype(bool))} | "
                     f"{np.sum(pc < 0.9 * wc)} / {np.sum(pc > 1.1 * wc)} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--min-pitch", type=float, default=0.0, help="deg: only problems whose |pitch| is at least this")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--summary", action="store_true", help="only print the table of OUT/problems.csv")
    a = ap.parse_args()
    if a.summary:
        print(summary(a.out / "problems.csv"))
        return
    data, cold, model, scene = load_problems()
    pitched = UVMSModel(model.params, model.water, ModelOptions(pitch_offset=np.pi / 2))
    ocps = {}
    rows = []
    for i in range(len(cold)):
        pitch = float(np.degrees(data["h0"][i][4]))
        if abs(pitch) < a.min_pitch:
            continue
        duals = None if cold[i] else (data["lam_g"][i], data["lam_x"][i])
        out = {"problem": i, "pitch_deg": pitch, "cold": bool(cold[i])}
        for name, m in (("world", model), ("pitched", pitched)):
            key = (name, int(data["contact"][i]))
            if key not in ocps:
                ocps[key] = ModeIIIOCP(m, scene.planes, key[1], ModeIIISettings())
            ocp = ocps[key]
            ocp.limit_inputs(data["lo"][i], data["hi"][i])
            h0, guess = data["h0"][i], data["guess"][i].copy()
            if m is pitched:
                h0 = model.angles_to_options(h0, pitched)
                N = ocp.settings.horizon
                nodes = np.concatenate([np.arange(k * ocp.nz, k * ocp.nz + ocp.ns) for k in range(N + 1)])
                guess[nodes] = model.angles_to_options(guess[nodes].reshape(-1, ocp.ns), pitched).ravel()
            sol = ocp.solve(h0, guess, data["current"][i], duals)
            out |= {f"{name}_usable": sol.status.usable, f"{name}_iterations": sol.iterations,
                    f"{name}_cost": sol.cost, f"{name}_ms": 1e3 * sol.solve_time}
        rows.append(out)
        print(out)
    a.out.mkdir(parents=True, exist_ok=True)
    with open(a.out / "problems.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(summary(a.out / "problems.csv"))


if __name__ == "__main__":
    from validation import manifest

    out = Path(sys.argv[sys.argv.index("--out") + 1]) if "--out" in sys.argv else Path(".")
    out.mkdir(parents=True, exist_ok=True)
    if "--summary" in sys.argv:
        main()
        sys.exit()
    with manifest.recorded(out / "manifest.json", {"pitch_offset": "pi/2", "problems": "out/mode3_problems.npz"}):
        main()
