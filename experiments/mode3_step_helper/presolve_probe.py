"""Offline probe (experiments/mode3_step_helper): on the Mode III problems recorded by
`python bench/mode3_solvers.py --record 2`, the iterations of each warm solve from the shifted plan
against the same solve started from the previous plan's successor solved ahead (from its next node).
Run from the repository root: python experiments/mode3_step_helper/presolve_probe.py"""

import sys

import numpy as np

sys.path.insert(0, "bench")
from mode3_solvers import load_problems, replayed

data, cold, model, scene = load_problems()
shifted, ahead_start, ahead_itself = [], [], []
prev = None
for i, ocp, sol in replayed(data, cold, model, scene):
    key = (int(data["contact"][i]), int(data["horizon"][i]))
    h0, current = data["h0"][i], data["current"][i]
    if not cold[i] and prev is not None and prev[0] == key and prev[1].status.usable:
        p = prev[1]
        node = p.h[1].copy()  # the plan's next node (its own states; the controller uses the recomputed ones)
        guess = ocp.pack(np.vstack([node, p.h[2:], p.h[-1:]]), np.vstack([p.u[1:], p.u[-1:]]),
                         np.vstack([p.force[1:], p.force[-1:]]))
        ahead = ocp.solve(node, guess, current, ocp.shifted_duals(p))
        if ahead.status.usable:
            start = ocp.pack(np.vstack([h0, ahead.h[1:]]), ahead.u, ahead.force)
            step = ocp.solve(h0, start, current, (ahead.lam_g, ahead.lam_x))
            shifted.append(sol.iterations)
            ahead_start.append(step.iterations)
            ahead_itself.append(ahead.iterations)
    prev = (key, sol) if sol.status.usable else None
A, B, H = map(np.array, (shifted, ahead_start, ahead_itself))


def q(v: np.ndarray) -> str:
    return (f"median {np.median(v):.0f} p90 {np.percentile(v, 90):.0f} p95 {np.percentile(v, 95):.0f} "
            f"max {v.max()} >=20: {(v >= 20).sum()}")


print(len(A), "pairs")
print("recorded warm start:", q(A))
print("from the solve ahead:", q(B))
print("the solve ahead itself:", q(H))
print("fewer / more / same:", (B < A).sum(), (B > A).sum(), (B == A).sum())
