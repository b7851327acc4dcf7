"""Paired per run: late Mode III steps among each episode's first three (python first_three.py A B), the
runs where A has more / B has more / ties and the exact two-sided sign test; then, per arm, late steps
by their place in the episode (first, second, third, later). Late: an overrun in strict real time, a
delay over 50 ms under a measured one."""

import glob
import json
import sys
from pathlib import Path

from scipy.stats import binomtest

PLACES = ("first", "second", "third", "later")


def late_by_place(root: str) -> dict[str, dict[str, tuple[int, int]]]:
    """(scenario/seed) -> place -> (late delayed Mode III steps there, delayed Mode III steps there)."""
    out = {}
    for path in glob.glob(f"{root}/**/summary.json", recursive=True):
        counts, prev, k = {p: [0, 0] for p in PLACES}, None, 0
        for s in json.load(open(path))["steps"]:
            k = k + 1 if s["mode"] == "III" and prev == "III" else 0
            prev = s["mode"]
            if s["mode"] == "III" and s["delay"] > 0:
                c = counts[PLACES[min(k, 3)]]
                c[0] += bool(s["overrun"] or s["delay"] > 0.05 + 1e-9)
                c[1] += 1
        p = Path(path).parts
        out[f"{p[-4]}/{p[-2]}"] = {q: tuple(c) for q, c in counts.items()}
    return out


a, b = (late_by_place(r) for r in sys.argv[1:3])
keys = sorted(set(a) & set(b))
first3 = {name: {k: sum(d[k][q][0] for q in PLACES[:3]) for k in keys} for name, d in (("a", a), ("b", b))}
more_a = sum(first3["a"][k] > first3["b"][k] for k in keys)
more_b = sum(first3["a"][k] < first3["b"][k] for k in keys)
p = binomtest(more_a, more_a + more_b).pvalue if more_a + more_b else 1.0
print(f"{len(keys)} paired runs: more late Mode III steps among the first three in {sys.argv[1]}: {more_a}, in "
      f"{sys.argv[2]}: {more_b}, ties {len(keys) - more_a - more_b}; exact sign test p = {p:.2g}")
for name, d in ((sys.argv[1], a), (sys.argv[2], b)):
    cells = []
    for q in PLACES:
        late, steps = sum(d[k][q][0] for k in keys), sum(d[k][q][1] for k in keys)
        cells.append(f"{q} {late}/{steps} ({100 * late / max(steps, 1):.1f} %)")
    print(f"{name}: late Mode III steps: " + ", ".join(cells))
