"""Offline probe (experiments/mode3_entry_intervals, the second step), run from the repository root after
`python bench/mode3_solvers.py --record 24 --latency 0.05` (the default: Mode III's first solve over two
intervals, the next over three; development seeds 0-23 of the three families at a fixed 50 ms delay):
python experiments/mode3_entry_intervals/probe_second_step.py

Each second Mode III step (the warm solve after a two-interval entry) solved as recorded, over three
intervals, and cut to its first two intervals (primal start and multipliers): IPOPT iterations and time."""

import sys

import numpy as np

sys.path.insert(0, "bench")
from mode3_solvers import cut, load_problems

from controller.mode3 import ModeIIIOCP, ModeIIISettings

data, cold, model, scene = load_problems()
second = [i + 1 for i in np.flatnonzero(cold) if data["horizon"][i] == 2 and i + 1 < len(cold) and not cold[i + 1]
          and data["horizon"][i + 1] == 3]
print(f"{len(second)} second steps after a two-interval entry; recorded at latency {data['latency']}, "
      f"settings overridden {data['ctl']}")
ocps: dict[tuple[int, int], ModeIIIOCP] = {}
rows: dict[int, list[tuple[float, float]]] = {3: [], 2: []}
for i in second:
    c = int(data["contact"][i])
    for N in rows:
        if (c, N) not in ocps:
            ocps[c, N] = ModeIIIOCP(model, scene.planes, c, ModeIIISettings(horizon=N))
        ocp = ocps[c, N]
        ocp.limit_inputs(data["lo"][i], data["hi"][i])
        guess, duals = cut(ocp, data["guess"][i], (data["lam_g"][i], data["lam_x"][i]), 3)
        sol = ocp.solve(data["h0"][i], guess, data["current"][i], duals)
        rows[N].append((sol.iterations if sol.status.usable else np.nan, 1e3 * sol.solve_time))
for N, r in rows.items():
    it, t = np.array(r).T
    print(f"over {N} intervals: usable {np.isfinite(it).sum()}/{len(it)}, iterations median {np.nanmedian(it):.0f} "
          f"p95 {np.nanpercentile(it, 95):.0f} max {np.nanmax(it):.0f}; time median {np.median(t):.0f} ms p95 "
          f"{np.percentile(t, 95):.0f} ms, over 40 ms in {(t > 40).sum()}")
faster = sum(b[1] < a[1] for a, b in zip(rows[3], rows[2], strict=True))
print(f"faster over 2 intervals in {faster} of {len(second)}")
