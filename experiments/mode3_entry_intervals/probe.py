"""Offline probe (experiments/mode3_entry_intervals), run from the repository root after
`python bench/mode3_solvers.py --record 24 --latency 0.05 --ctl mode3_entry_intervals=none`
(Mode III's problems of the three families, development seeds 0-23, at a fixed 50 ms delay, each
first solve over the whole horizon): python experiments/mode3_entry_intervals/probe.py

1. Each cold first solve (Algorithm 2's guess) cut to N = 1, 2, 3 intervals: IPOPT iterations and time.
2. The step after each, as recorded (started from the three-interval plan), against the same step
   started from the N-interval plan held over the horizon (ModeIIIOCP.held_over), its states
   recomputed as the controller does (SwitchingNMPC._resimulate's RK4, tip put back on the plane)."""

import sys

import numpy as np

sys.path.insert(0, "bench")
from mode3_solvers import cut, load_problems

from controller.mode3 import ModeIIIOCP, ModeIIISettings

data, cold, model, scene = load_problems()
first = [i for i in np.flatnonzero(cold) if i + 1 < len(cold) and not cold[i + 1] and data["horizon"][i] == 3]
print(f"{len(first)} cold three-interval first solves followed by a warm step; recorded at latency "
      f"{data['latency'] if 'latency' in data else '?'} with {data['ctl'] if 'ctl' in data else '?'}")


def q(v: np.ndarray, unit: str = "") -> str:
    return f"median {np.median(v):.0f}{unit} p95 {np.percentile(v, 95):.0f}{unit} max {np.max(v):.0f}{unit}"


def recomputed(ocp: ModeIIIOCP, h0: np.ndarray, us: np.ndarray, forces: np.ndarray, current: np.ndarray):
    hs = [np.asarray(h0, float)]
    for k, uk in enumerate(us):
        h = model.held_steps(hs[-1], uk, ocp.settings.dt, 4, Fw=np.concatenate([forces[k], np.zeros(3)]), Rw=ocp.Rw,
                             vc=current)
        h[6:6 + model.n_joints] = ocp.onto_plane(h)
        hs.append(h)
    return np.array(hs)


ocps: dict[tuple[int, int], ModeIIIOCP] = {}
for N in (1, 2, 3):
    its, times, usable, second = [], [], 0, []
    for i in first:
        c = int(data["contact"][i])
        for n in {N, 3}:
            if (c, n) not in ocps:
                ocps[c, n] = ModeIIIOCP(model, scene.planes, c, ModeIIISettings(horizon=n))
            ocps[c, n].limit_inputs(data["lo"][i], data["hi"][i])
        short, full = ocps[c, N], ocps[c, 3]
        sol = short.solve(data["h0"][i], cut(short, data["guess"][i], None, 3)[0], data["current"][i])
        its.append(sol.iterations)
        times.append(1e3 * sol.solve_time)
        usable += sol.status.usable
        if sol.status.usable:
            plan = short.held_over(sol, 3)
            states = recomputed(full, data["h0"][i], plan.u, plan.force, data["current"][i])
            h1 = data["h0"][i + 1]
            guess = full.pack(np.vstack([h1, states[2:], states[-1:]]), np.vstack([plan.u[1:], plan.u[-1:]]),
                              np.vstack([plan.force[1:], plan.force[-1:]]))
            nxt = full.solve(h1, guess, data["current"][i + 1], full.shifted_duals(plan))
            second.append(nxt.iterations if nxt.status.usable else np.nan)
    print(f"N = {N}: cold first solve usable {usable}/{len(first)}, iterations {q(np.array(its))}, "
          f"time {q(np.array(times), ' ms')}")
    s = np.array(second)
    print(f"       the next step from its plan held over 3 intervals: usable {np.isfinite(s).sum()}/{len(s)}, "
          f"iterations {q(s[np.isfinite(s)])}")
rec = []
for i in first:
    ocp = ocps[int(data["contact"][i]), 3]
    ocp.limit_inputs(data["lo"][i + 1], data["hi"][i + 1])
    r = ocp.solve(data["h0"][i + 1], data["guess"][i + 1], data["current"][i + 1],
                  (data["lam_g"][i + 1], data["lam_x"][i + 1]))
    rec.append(r.iterations if r.status.usable else np.nan)
r = np.array(rec)
print(f"the next step as recorded (from the closed loop's three-interval plan): usable "
      f"{np.isfinite(r).sum()}/{len(r)}, iterations {q(r[np.isfinite(r)])}")
