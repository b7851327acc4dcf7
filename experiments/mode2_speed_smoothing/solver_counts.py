"""Per run, one mode's IPOPT work in two arms' runs, family by family, paired by seed: iterations
summed over the run's steps in that mode, its steps at the mode's iteration cap and its fallbacks,
with the exact sign test of which arm takes fewer iterations; the mode's step times pooled.
Iterations, caps and fallbacks are deterministic; times follow the shared host.

  python experiments/mode2_speed_smoothing/solver_counts.py <first arm folder> <second arm folder> [II|III]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from validation.statistics import sign_test


def runs(folder: Path) -> dict[tuple[str, int], dict]:
    """(family, seed) -> summary, over the arm's campaign folders."""
    return {(s["scenario"]["name"], s["mismatch"]["seed"]): s for f in folder.rglob("summary.json")
            for s in [json.loads(f.read_text())]}


CAPS = {"II": 100, "III": 200}  # the modes' max_iter (controller.mode2, controller.mode3)


def counts(summary: dict, mode: str) -> tuple[int, int, int]:
    """The mode's iterations, steps at its cap and fallbacks over one run (the switching step at t = 0,
    reported as Mode II's, counts with its Mode II solve)."""
    steps = [s for s in summary["steps"] if s["mode"] == mode]
    return (sum(s["iterations"] for s in steps), sum(s["iterations"] >= CAPS[mode] for s in steps),
            sum(s["fallback"] != "none" for s in steps))


def main(first: Path, second: Path, mode: str = "II") -> None:
    a, b = runs(first), runs(second)
    for family in sorted({k[0] for k in a}):
        keys = sorted(k for k in set(a) & set(b) if k[0] == family)
        per_run = [{k: counts(d[k], mode) for k in keys} for d in (a, b)]
        test = sign_test({k: c[0] for k, c in per_run[0].items()}, {k: c[0] for k, c in per_run[1].items()},
                         lower_is_better=True)
        line = [f"{family}: {len(keys)} runs"]
        for name, c in zip((first.name, second.name), per_run, strict=True):
            v = np.array(list(c.values()))
            line.append(f"{name}: iterations median {np.median(v[:, 0]):.0f} per run, at the cap {v[:, 1].sum()}, "
                        f"fallbacks {v[:, 2].sum()} (runs with one {int((v[:, 2] > 0).sum())})")
        print("; ".join(line) + f"; {second.name} fewer iterations in {test.b_better} runs, more in "
              f"{test.a_better}, ties {test.ties} (sign test p = {test.p_value:.2g})")
        for name, d in ((first.name, a), (second.name, b)):
            t = 1e3 * np.array([s["compute_time"] for k in keys for s in d[k]["steps"] if s["mode"] == mode])
            q = np.percentile(t, [50, 95, 99])
            print(f"  {name}: Mode {mode} steps {len(t)}, median {q[0]:.0f} p95 {q[1]:.0f} p99 {q[2]:.0f} "
                  f"max {t.max():.0f} ms")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]), *sys.argv[3:4])
