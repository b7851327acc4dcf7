"""Thrusters-dead's hull contacts against the unknown current's draw (positive: onto the wall), one arm."""
import glob
import json
import sys

from scipy.stats import fisher_exact

table = [[0, 0], [0, 0]]
for f in glob.glob(f"{sys.argv[1]}/runs/thrusters-dead/switching/*/summary.json"):
    s = json.load(open(f))
    onto = s["mismatch"]["values"]["current"] > 0.03
    table[int(onto)][int(s["verdict"] == "hull contact")] += 1
print(f"{sys.argv[1]}: current <= 0.03 m/s: {table[0][1]} hull contacts of {sum(table[0])}; > 0.03 m/s onto the wall: "
      f"{table[1][1]} of {sum(table[1])} (Fisher's exact p = {fisher_exact(table).pvalue:.2g})")
