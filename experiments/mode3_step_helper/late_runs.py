"""Paired per run: late Mode III steps after its first (python late_runs.py A B), the runs where A
has more / B has more / ties, and the exact two-sided sign test; then the steps' totals. Late: an
overrun in strict real time, a delay over 50 ms under a measured one."""

import glob
import json
import sys
from pathlib import Path

from scipy.stats import binomtest


def late_later_mode3(root: str) -> dict[str, tuple[int, int]]:
    """(scenario/seed) -> (late Mode III steps after each entry's first, such steps)."""
    out = {}
    for path in glob.glob(f"{root}/**/summary.json", recursive=True):
        late = steps = 0
        prev = None
        for s in json.load(open(path))["steps"]:
            if s["mode"] == "III" and s["delay"] > 0 and prev == "III":
                steps += 1
                late += bool(s["overrun"] or s["delay"] > 0.05 + 1e-9)
            prev = s["mode"]
        p = Path(path).parts
        out[f"{p[-4]}/{p[-2]}"] = (late, steps)
    return out


a, b = (late_later_mode3(r) for r in sys.argv[1:3])
keys = sorted(set(a) & set(b))
more_a = sum(a[k][0] > b[k][0] for k in keys)
more_b = sum(a[k][0] < b[k][0] for k in keys)
p = binomtest(more_a, more_a + more_b).pvalue if more_a + more_b else 1.0
print(f"{len(keys)} paired runs: more late Mode III steps (after the first) in {sys.argv[1]}: {more_a}, "
      f"in {sys.argv[2]}: {more_b}, ties {len(keys) - more_a - more_b}; exact sign test p = {p:.2g}")
for name, d in ((sys.argv[1], a), (sys.argv[2], b)):
    late, steps = sum(d[k][0] for k in keys), sum(d[k][1] for k in keys)
    print(f"{name}: {late}/{steps} late ({100 * late / max(steps, 1):.1f} %)")
