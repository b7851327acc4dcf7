"""Mode III's IPOPT iterations in two campaign folders, paired by run: the declared measure of
experiments/mode3_regular_pitch.

  PYTHONPATH=. python experiments/mode3_regular_pitch/iterations.py A B   # folders with runs/

Per run, the median iterations over its Mode III steps; the sign test over the runs with Mode III
steps in both; the pooled steps' median / p95 / max; and the Mode III steps whose solve was not
usable (a fallback acted).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from validation.statistics import sign_test


def mode3_steps(folder: Path) -> dict[tuple, list[dict]]:
    """Each run's Mode III steps, by (scenario, seed)."""
    out = {}
    for f in sorted(folder.glob("runs/*/*/seed-*/summary.json")):
        s = json.loads(f.read_text())
        out[(f.parents[2].name, int(f.parent.name.split("-")[1]))] = [x for x in s["steps"] if x["mode"] == "III"]
    return out


def main(a: Path, b: Path) -> None:
    steps = {a: mode3_steps(a), b: mode3_steps(b)}
    med = {k: {run: float(np.median([x["iterations"] for x in v])) if v else np.nan for run, v in s.items()}
           for k, s in steps.items()}
    t = sign_test(med[a], med[b], lower_is_better=True)
    print(f"runs: {len(steps[a])} / {len(steps[b])}; per-run median of Mode III iterations, {a.name} vs {b.name}: "
          f"{a.name} fewer in {t.a_better}, more in {t.b_better}, ties {t.ties}, median difference "
          f"{t.median_difference:+.1f}, sign test p = {t.p_value:.2g}")
    print("| arm | Mode III steps | iterations median / p95 / max | steps with a fallback |\n|---|---|---|---|")
    for k, s in steps.items():
        it = np.array([x["iterations"] for v in s.values() for x in v])
        fb = sum(x["fallback"] != "none" for v in s.values() for x in v)
        print(f"| {k.name} | {len(it)} | {np.median(it):.0f} / {np.percentile(it, 95):.0f} / {it.max()} | {fb} |")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit("usage: iterations.py A B (two campaign folders with runs/)")
    main(Path(sys.argv[1]), Path(sys.argv[2]))
