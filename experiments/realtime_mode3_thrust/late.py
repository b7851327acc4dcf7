"""Late steps per mode and step medians from run summaries: python late.py DIR [DIR ...].

Counts, per mode, the overruns among the steps with a delay (the first step acts at once) and the
median whole-step computation time, over every summary.json under each folder; then Mode II's
overruns by its horizon N (Algorithm 1 shortens it every step)."""

import collections
import glob
import json
import statistics
import sys

BANDS = ((1, 4), (5, 8), (9, 20))  # Mode II horizons

for root in sys.argv[1:]:
    steps, late, times = collections.Counter(), collections.Counter(), collections.defaultdict(list)
    by_n, late_n = collections.Counter(), collections.Counter()
    for path in glob.glob(f"{root}/**/summary.json", recursive=True):
        for s in json.load(open(path))["steps"]:
            if s["delay"] > 0:
                steps[s["mode"]] += 1
                late[s["mode"]] += s["overrun"]
                times[s["mode"]].append(s["compute_time"])
                if s["mode"] == "II":
                    band = next(b for b in BANDS if b[0] <= s["horizon"] <= b[1])
                    by_n[band] += 1
                    late_n[band] += s["overrun"]
    print(root, "  ".join(f"{m}: {late[m]}/{steps[m]} late ({100 * late[m] / steps[m]:.0f} %), median "
                          f"{1000 * statistics.median(times[m]):.0f} ms" for m in sorted(steps)))
    print("  Mode II by horizon:", "  ".join(f"N {lo}-{hi}: {late_n[lo, hi]}/{by_n[lo, hi]} late"
                                            for lo, hi in BANDS if by_n[lo, hi]))
