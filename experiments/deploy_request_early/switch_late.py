"""Paired per run: late switching steps (Mode II's first step after Mode I, delayed) (python switch_late.py
A B), the runs where A has more / B has more / ties and the exact two-sided sign test; then, per arm,
the late switching steps with the IPOPT iterations of late and of timely ones (median). Late: an
overrun in strict real time, a delay over 50 ms under a measured one."""

import glob
import json
import statistics
import sys
from pathlib import Path

from scipy.stats import binomtest


def switches(root: str) -> dict[str, list[tuple[bool, int]]]:
    """(scenario/seed) -> [(late, iterations)] of its delayed switching steps."""
    out = {}
    for path in glob.glob(f"{root}/**/summary.json", recursive=True):
        rows, prev = [], None
        for s in json.load(open(path))["steps"]:
            if s["mode"] == "II" and prev == "I" and s["delay"] > 0:
                rows.append((bool(s["overrun"] or s["delay"] > 0.05 + 1e-9), s["iterations"]))
            prev = s["mode"]
        p = Path(path).parts
        out[f"{p[-4]}/{p[-2]}"] = rows
    return out


a, b = (switches(r) for r in sys.argv[1:3])
keys = sorted(set(a) & set(b))
late = {n: {k: sum(x for x, _ in d[k]) for k in keys} for n, d in (("a", a), ("b", b))}
more_a = sum(late["a"][k] > late["b"][k] for k in keys)
more_b = sum(late["a"][k] < late["b"][k] for k in keys)
p = binomtest(more_a, more_a + more_b).pvalue if more_a + more_b else 1.0
print(f"{len(keys)} paired runs: more late switching steps in {sys.argv[1]}: {more_a}, in {sys.argv[2]}: {more_b}, "
      f"ties {len(keys) - more_a - more_b}; exact sign test p = {p:.2g}")
for name, d in ((sys.argv[1], a), (sys.argv[2], b)):
    rows = [r for k in keys for r in d[k]]
    its = {flag: [i for x, i in rows if x == flag] for flag in (True, False)}
    med = {flag: statistics.median(v) if v else float("nan") for flag, v in its.items()}
    print(f"{name}: switching steps late {len(its[True])}/{len(rows)}; IPOPT iterations median: late "
          f"{med[True]}, timely {med[False]}")
