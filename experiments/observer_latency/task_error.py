"""Final task error [m] per run, paired by scenario and seed (python task_error.py OUT/part1):
medians per arm, the runs each arm ends closer to its station, and the exact two-sided sign test."""

import csv
import statistics
import sys
from math import comb
from pathlib import Path


def errors(folder: Path) -> dict[tuple[str, str], float]:
    rows = csv.DictReader(open(folder / "results.csv"))
    return {(r["scenario"], r["seed"]): float(r["final_task_error"]) for r in rows}


root = Path(sys.argv[1])
base, new = errors(root / "default"), errors(root / "observed")
pairs = [(base[k], new[k]) for k in sorted(base.keys() & new.keys())]
better = sum(n < b for b, n in pairs)
worse = sum(n > b for b, n in pairs)
m = better + worse
p = min(1.0, 2 * sum(comb(m, i) for i in range(min(better, worse) + 1)) / 2**m) if m else 1.0
print(f"{len(pairs)} pairs: median final task error {statistics.median(b for b, _ in pairs):.4f} m (default) "
      f"vs {statistics.median(n for _, n in pairs):.4f} m (observed); observed closer in {better}, "
      f"further in {worse}, ties {len(pairs) - m}; exact sign test p = {p:.2g}")
for scenario in sorted({k[0] for k in base}):
    sub = [(base[k], new[k]) for k in sorted(base.keys() & new.keys()) if k[0] == scenario]
    print(f"  {scenario}: {statistics.median(b for b, _ in sub):.4f} vs {statistics.median(n for _, n in sub):.4f} m, "
          f"closer in {sum(n < b for b, n in sub)} of {len(sub)}")
