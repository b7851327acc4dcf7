"""Per run, the longest step of two campaign folders' thrusters-dead runs, and the exact sign test of
which is shorter; Mode II's steps pooled (the switching step at t = 0 is reported as Mode II's).

  python experiments/certificate_cap100/longest_step.py <first folder> <second folder>
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from scipy.stats import binomtest


def runs(folder: Path) -> dict[int, dict]:
    return {s["mismatch"]["seed"]: s for f in (folder / "runs" / "thrusters-dead").rglob("summary.json")
            for s in [json.loads(f.read_text())]}


def main(first: Path, second: Path) -> None:
    a, b = runs(first), runs(second)
    keys = sorted(set(a) & set(b))
    longest = [np.array([max(s["compute_time"] for s in d[k]["steps"]) for k in keys]) for d in (a, b)]
    shorter, longer = int(np.sum(longest[1] < longest[0])), int(np.sum(longest[1] > longest[0]))
    p = binomtest(shorter, shorter + longer).pvalue if shorter + longer else 1.0
    print(f"{len(keys)} runs; longest step, median: {np.median(longest[0]):.2f} / {np.median(longest[1]):.2f} s; "
          f"the second shorter in {shorter}, longer in {longer}, sign test p = {p:.2g}")
    for name, d in ((first.name, a), (second.name, b)):
        t = 1e3 * np.array([s["compute_time"] for k in keys for s in d[k]["steps"] if s["mode"] == "II"])
        q = np.percentile(t, [50, 95, 99])
        cert = np.median([d[k]["steps"][0]["certificate"]["seconds"] for k in keys])
        print(f"{name}: Mode II steps {len(t)}, median {q[0]:.0f} p95 {q[1]:.0f} p99 {q[2]:.0f} max {t.max():.0f} ms; "
              f"the first step's certificate {cert:.2f} s (median)")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
