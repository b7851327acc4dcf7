"""Answer ages and following steps of the asynchronous runs (per mode)."""
import glob
import json
import sys

import numpy as np

st, fol = {}, {}
for f in glob.glob(sys.argv[1] + '/runs/**/summary.json', recursive=True):
    s = json.load(open(f))
    for r in s['steps'][1:]:
        m = r['mode']
        if r['fallback'].startswith('following'):
            fol[m] = fol.get(m, 0) + 1
        else:
            st.setdefault(m, []).append(r['solve_time'])
for m, v in sorted(st.items()):
    v = np.array(v) * 1000
    print(f"| {m} | {len(v)} | {np.median(v):.0f} | {np.percentile(v, 95):.0f} | {v.max():.0f} | {fol.get(m, 0)} |")
