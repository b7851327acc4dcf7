"""Step times of two campaign folders' runs, side by side: per mode, the pooled steps' median, p95,
p99, max [ms] and share over 50 ms; the certificate's methods over Mode I's steps; per run, Mode
I's p95 and median step, and the exact sign test of which arm's is lower (runs with Mode I steps).

  python experiments/refined_certificate/step_times.py <folder> <first arm> <second arm>
"""

from __future__ import annotations

import json
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.stats import binomtest


def runs(folder: Path) -> dict[tuple[str, int], dict]:
    """Every run's summary by (scenario, mismatch seed)."""
    out = {}
    for f in (folder / "runs").rglob("summary.json"):
        d = json.loads(f.read_text())
        name = d["scenario"] if isinstance(d["scenario"], str) else d["scenario"]["name"]
        out[(name, d["mismatch"]["seed"])] = d
    return out


def mode_one(stat: Callable[[list[float]], float]) -> Callable[[dict], float]:
    """A statistic of a run's Mode I step times [s] (nan without Mode I steps)."""
    def of(run: dict) -> float:
        t = [s["compute_time"] for s in run["steps"] if s["mode"] == "I"]
        return float(stat(t)) if t else np.nan
    return of


def main(folder: Path, first: str, second: str) -> None:
    data = {arm: runs(folder / arm) for arm in (first, second)}
    keys = sorted(set(data[first]) & set(data[second]))
    print(f"paired runs {len(keys)}")
    for arm in (first, second):
        steps = [s for k in keys for s in data[arm][k]["steps"]]
        for m in ("I", "II", "III"):
            t = 1e3 * np.array([s["compute_time"] for s in steps if s["mode"] == m])
            if len(t):
                q = np.percentile(t, [50, 95, 99])
                print(f"{arm:8s} {m:3s} steps {len(t):5d} median {q[0]:6.1f} p95 {q[1]:7.1f} p99 {q[2]:7.1f} "
                      f"max {t.max():7.1f} >50ms {100 * np.mean(t > 50):5.1f}%")
        methods = Counter(s["certificate"]["method"] for s in steps if s["mode"] == "I" and s.get("certificate"))
        print("  methods (Mode I steps):", dict(methods))
    for name, stat in (("p95", mode_one(lambda t: np.percentile(t, 95))), ("median", mode_one(np.median))):
        a = np.array([stat(data[first][k]) for k in keys])
        b = np.array([stat(data[second][k]) for k in keys])
        ok = np.isfinite(a) & np.isfinite(b)
        lower, higher = int(np.sum(b[ok] < a[ok])), int(np.sum(b[ok] > a[ok]))
        p = binomtest(lower, lower + higher).pvalue if lower + higher else 1.0
        print(f"per-run Mode I {name}: {second} lower in {lower}, higher in {higher}, sign test p = {p:.2g}")
    for family in sorted({k[0] for k in keys}):
        ks = [k for k in keys if k[0] == family]
        n = [sum(s["mode"] == "I" for k in ks for s in data[arm][k]["steps"]) for arm in (first, second)]
        if all(n):
            med = [1e3 * np.nanmedian([mode_one(np.median)(data[arm][k]) for k in ks]) for arm in (first, second)]
            print(f"{family}: median of per-run Mode I median {med[0]:.1f} / {med[1]:.1f} ms, "
                  f"Mode I steps {n[0]} / {n[1]}")


if __name__ == "__main__":
    main(Path(sys.argv[1]), sys.argv[2], sys.argv[3])
