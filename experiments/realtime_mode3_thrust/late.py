"""Late steps per mode and step medians from run summaries: python late.py DIR [DIR ...].

Counts, per mode, the overruns among the steps with a delay (the first step acts at once) and the
median whole-step computation time, over every summary.json under each folder."""

import collections
import glob
import json
import statistics
import sys

for root in sys.argv[1:]:
    steps, late, times = collections.Counter(), collections.Counter(), collections.defaultdict(list)
    for path in glob.glob(f"{root}/**/summary.json", recursive=True):
        for s in json.load(open(path))["steps"]:
            if s["delay"] > 0:
                steps[s["mode"]] += 1
                late[s["mode"]] += s["overrun"]
                times[s["mode"]].append(s["compute_time"])
    print(root, "  ".join(f"{m}: {late[m]}/{steps[m]} late ({100 * late[m] / steps[m]:.0f} %), median "
                          f"{1000 * statistics.median(times[m]):.0f} ms" for m in sorted(steps)))
