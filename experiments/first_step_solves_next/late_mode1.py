"""Paired per run: late delayed Mode I steps (python late_mode1.py A B), the runs where A has more / B
has more / ties and the exact two-sided sign test; then, per arm, Mode I's late delayed steps: the
episode's first delayed step (the step after the first, whose input acts at once) and the others,
with the median whole-step time of each. Late: an overrun in strict real time, a delay over 50 ms
under a measured one."""

import glob
import json
import statistics
import sys
from pathlib import Path

from scipy.stats import binomtest


def mode1_steps(root: str) -> dict[str, list[tuple[int, bool, float]]]:
    """(scenario/seed) -> [(step index, late, whole-step seconds)] of the delayed Mode I steps."""
    out = {}
    for path in glob.glob(f"{root}/**/summary.json", recursive=True):
        p = Path(path).parts
        out[f"{p[-4]}/{p[-2]}"] = [(k, bool(s["overrun"] or s["delay"] > 0.05 + 1e-9), s["compute_time"])
                                   for k, s in enumerate(json.load(open(path))["steps"])
                                   if s["mode"] == "I" and s["delay"] > 0]
    return out


a, b = (mode1_steps(r) for r in sys.argv[1:3])
keys = sorted(set(a) & set(b))
count = {name: {k: sum(late for _, late, _ in d[k]) for k in keys} for name, d in (("a", a), ("b", b))}
more_a = sum(count["a"][k] > count["b"][k] for k in keys)
more_b = sum(count["a"][k] < count["b"][k] for k in keys)
p = binomtest(more_a, more_a + more_b).pvalue if more_a + more_b else 1.0
print(f"{len(keys)} paired runs: more late Mode I steps in {sys.argv[1]}: {more_a}, in {sys.argv[2]}: "
      f"{more_b}, ties {len(keys) - more_a - more_b}; exact sign test p = {p:.2g}")
for name, d in ((sys.argv[1], a), (sys.argv[2], b)):
    cells = []
    for place, pick in (("step 1", lambda k: k == 1), ("others", lambda k: k != 1)):
        rows = [(late, sec) for key in keys for k, late, sec in d[key] if pick(k)]
        if rows:
            cells.append(f"{place} {sum(r[0] for r in rows)}/{len(rows)} late, median "
                         f"{1000 * statistics.median(r[1] for r in rows):.0f} ms")
    print(f"{name}: delayed Mode I steps: " + "; ".join(cells))
