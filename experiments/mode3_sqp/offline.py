"""Mode III's recorded problems (bench/mode3_solvers.py --record) solved by IPOPT (the default),
controller.sqp's SQP with the Lagrangian's Hessian (3 and 10 iterations, from the recorded
multipliers) and fatrop (CasADi's plugin, on the lifted problem of lifted_fatrop.py), one after the
other on each problem.

  PYTHONPATH=. python experiments/mode3_sqp/offline.py [--every K]   (writes offline.md, offline.manifest.json)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

HERE = Path(__file__).parent
sys.path[:0] = [str(HERE), str(HERE.parents[1] / "bench")]

from lifted_fatrop import LiftedFatrop  # noqa: E402
from mode3_solvers import load_problems  # noqa: E402

from controller.mode3 import ModeIIIOCP, ModeIIISettings  # noqa: E402
from controller.model import water  # noqa: E402
from controller.sqp import Hessian, SQPSettings, StageSQP  # noqa: E402
from validation import manifest  # noqa: E402

SQP = {"SQP, 3 iterations (the closed loop's)": 3, "SQP, 10 iterations": 10}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--every", type=int, default=1, help="every K-th recorded problem")
    a = ap.parse_args()
    with manifest.recorded(HERE / "offline.manifest.json", {"every": a.every}):
        data, cold, model, scene = load_problems()
        ocps, rows = {}, {k: [] for k in ["IPOPT (default)", *SQP, "fatrop"]}
        picked = [i for i in range(len(cold)) if i % a.every == 0 and not cold[i]]
        for i in tqdm(picked, desc="problems", unit="problem"):
            c = int(data["contact"][i])
            if c not in ocps:
                o = ModeIIIOCP(model, scene.planes, c, ModeIIISettings())
                alg = range(model.n_inputs, model.n_inputs + model.n_speeds)
                sqps = {k: StageSQP(o.problem, o.name, algebraic=alg, settings=SQPSettings(
                    max_iter=n, hessian=Hessian.LAGRANGIAN, line_search=True)) for k, n in SQP.items()}
                ocps[c] = (o, sqps, LiftedFatrop(o.problem, o.name, {"print_level": 0, "tol": 1e-6}))
            o, sqps, fat = ocps[c]
            o.limit_inputs(data["lo"][i], data["hi"][i])
            lbw, ubw = o.bounds()
            s, ns = o.settings, o.ns
            P = np.concatenate([data["h0"][i], water(data["current"][i]), [s.hull_clearance, s.clearance_weight],
                                o.weights])
            lbg, ubg = o.lbg[ns:], o.ubg[ns:]
            judge = next(iter(sqps.values()))
            sol = o.solve(data["h0"][i], data["guess"][i], data["current"][i], (data["lam_g"][i], data["lam_x"][i]))
            v, J = judge.evaluate(sol.w, P, lbg, ubg)
            rows["IPOPT (default)"].append((sol.status.usable, sol.iterations, sol.solve_time, J, v))
            x0 = np.clip(data["guess"][i], lbw, ubw)
            for k, q in sqps.items():
                r = q.solve(x0, P, lbw, ubw, lbg, ubg, lam=data["lam_g"][i][ns:])
                rows[k].append((r.status.usable, r.iterations, r.solve_time, r.cost, r.violation))
            t0 = time.perf_counter()
            w, st = fat.solve(x0, P, lbw, ubw, o.lbg, o.ubg)
            t = time.perf_counter() - t0
            v, J = judge.evaluate(w, P, lbg, ubg)
            rows["fatrop"].append((st["return_status"] == 0, st["iter_count"], t, J, v))
        base = np.array([r[3] for r in rows["IPOPT (default)"]])
        lines = ["| solver | usable | iterations median / p95 | time median / p95 [ms] | ms per iteration | "
                 "largest violation: median / p95 | cost - IPOPT's: median |", "|---|---|---|---|---|---|---|"]
        for k, v in rows.items():
            ok, it, t, J, viol = (np.array(c, float) for c in zip(*v, strict=True))
            lines.append(f"| {k} | {int(ok.sum())}/{len(ok)} | {np.median(it):.0f} / {np.percentile(it, 95):.0f} | "
                         f"{1e3 * np.median(t):.0f} / {1e3 * np.percentile(t, 95):.0f} | "
                         f"{1e3 * t.sum() / it.sum():.1f} | {np.median(viol):.1e} / {np.percentile(viol, 95):.1e} | "
                         f"{np.median(J - base):+.1e} |")
        (HERE / "offline.md").write_text(
            f"`PYTHONPATH=. python experiments/mode3_sqp/offline.py --every {a.every}`: the {len(picked)} warm-started "
            "Mode III problems recorded by `python bench/mode3_solvers.py --record 2` (wall-headon, wall-oblique, "
            "arm-deployed, seeds 0-1), each solved by every solver in turn. Violation: the largest of the stage "
            "constraints (m, N, N m).\n\n" + "\n".join(lines) + "\n")
        print("\n".join(lines))


if __name__ == "__main__":
    main()
