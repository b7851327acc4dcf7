"""Mode III's first steps after Mode II: how many overran and their median whole-step time and
iterations, over every summary.json under each folder: python entries.py DIR [DIR ...]."""

import glob
import json
import statistics
import sys

for root in sys.argv[1:]:
    late, times, iters = [], [], []
    for path in glob.glob(f"{root}/**/summary.json", recursive=True):
        previous = None
        for s in json.load(open(path))["steps"]:
            if s["mode"] == "III" and previous == "II" and s["delay"] > 0:
                late.append(s["overrun"])
                times.append(s["compute_time"])
                iters.append(s["iterations"])
            previous = s["mode"]
    if late:
        print(f"{root}: Mode III entries {len(late)}, late {sum(late)} ({100 * sum(late) / len(late):.0f} %), "
              f"median {1000 * statistics.median(times):.0f} ms, {statistics.median(iters):.0f} iterations")
