"""Exploration for the switching NMPC: how fast can IPOPT solve a Mode-I-like OCP on the
paper's model without code generation? Not the controller: a baseline to beat.

OCP: N = 20, dt = 0.1 s, one RK4 step per interval on controller.model.UVMSModel (20 states, 12
inputs), quadratic tracking cost, input bounds, every body's distance to the default wall >= 2 cm;
the vehicle starts 2 m from the wall moving at 0.3 m/s towards it; the target is 1 m ahead.
Variables ordered [x0, u0, x1, u1, ..., xN]. Variants: the NLP as an MX graph calling the per-stage
SX functions, or expanded to one SX graph; IPOPT's exact Hessian or a constant Gauss-Newton
Hessian of the cost (`hess_lag`). Each variant: build time, then three solves, each warm-started
from the previous solution. Run: `python bench/ocp_formulations.py` (several minutes); writes
bench/results/ocp_formulations.json and .md.
"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import casadi as ca
import numpy as np

from controller.model import WATER, UVMSModel
from uvms import load_params, load_scene

OUT = Path(__file__).parent / "results"
N, DT, MARGIN = 20, 0.1, 0.02


def build(sym, hessian: str):
    params, scene = load_params(), load_scene()
    model = UVMSModel(params, scene.water)
    ns, nu = params.n_states, params.n_inputs
    h, u = ca.SX.sym("h", ns), ca.SX.sym("u", nu)
    still = (ca.DM.zeros(6), ca.DM.eye(3), ca.DM.zeros(WATER), ca.DM.zeros(3))
    F = ca.Function("F", [h, u], [model.rk4(h, u, *still, DT)])
    wall = scene.planes[0]
    D = ca.Function("D", [h], [model.distances(h, ca.DM(wall.normal), wall.offset)])
    nw = N * (ns + nu) + ns
    w, P = sym.sym("w", nw), sym.sym("P", 2 * ns)
    X = ca.horzcat(*[w[k * (ns + nu):k * (ns + nu) + ns] for k in range(N + 1)])
    U = ca.horzcat(*[w[k * (ns + nu) + ns:(k + 1) * (ns + nu)] for k in range(N)])
    x0, xr = P[:ns], P[ns:]
    Ws = np.ones(ns)
    Ws[:3], Ws[3:6] = 10.0, 5.0
    Wu = np.full(nu, 1e-3)
    E = X[:, 1:] - ca.repmat(xr, 1, N)
    J = ca.sum2(ca.sum1((Ws[:, None] * E) * E)) + ca.sum2(ca.sum1((Wu[:, None] * U) * U))
    g = ca.veccat(X[:, 0] - x0, X[:, 1:] - F.map(N)(X[:, :-1], U), D.map(N)(X[:, 1:]))
    opts = {"print_time": False, "ipopt": {"print_level": 0, "max_iter": 200, "tol": 1e-6,
                                           "warm_start_init_point": "yes"}}
    if hessian == "gauss-newton":
        lam_f, lam_g = sym.sym("lf"), sym.sym("lg", g.shape[0])
        opts["hess_lag"] = ca.Function("nlp_hess_l", [w, P, lam_f, lam_g], [ca.triu(lam_f * ca.hessian(J, w)[0])])
    solver = ca.nlpsol("s", "ipopt", {"x": w, "p": P, "f": J, "g": g}, opts)
    lo, hi = params.input_bounds()
    lbw, ubw = np.full(nw, -np.inf), np.full(nw, np.inf)
    for k in range(N):
        i = k * (ns + nu) + ns
        lbw[i:i + nu], ubw[i:i + nu] = lo, hi
    nd = D.size1_out(0) * N
    lbg, ubg = np.zeros(g.shape[0]), np.zeros(g.shape[0])
    lbg[-nd:], ubg[-nd:] = MARGIN, np.inf
    h0 = np.zeros(ns)
    h0[6:6 + params.n_joints] = params.arm.home
    h0[6 + params.n_joints] = 0.3
    ref = np.zeros(ns)
    ref[0], ref[6:6 + params.n_joints] = 1.0, params.arm.home
    return solver, dict(lbx=lbw, ubx=ubw, lbg=lbg, ubg=ubg, p=np.concatenate([h0, ref])), \
        np.concatenate([np.concatenate([h0, np.zeros(nu)]) for _ in range(N)] + [h0])


def main() -> None:
    rows = []
    for graph, sym in (("MX", ca.MX), ("SX (expanded)", ca.SX)):
        for hessian in ("exact", "gauss-newton"):
            if graph.startswith("SX") and hessian == "exact":
                continue  # its Hessian graph takes minutes to build
            t0 = time.perf_counter()
            solver, bounds, w0 = build(sym, hessian)
            built = time.perf_counter() - t0
            solves = []
            for _ in range(3):
                t0 = time.perf_counter()
                r = solver(x0=w0, **bounds)
                st = solver.stats()
                solves.append({"seconds": time.perf_counter() - t0, "iterations": st["iter_count"],
                               "status": st["return_status"]})
                w0 = np.asarray(r["x"]).ravel()
            rows.append({"graph": graph, "hessian": hessian, "build_seconds": built, "solves": solves})
            print(rows[-1])
    OUT.mkdir(exist_ok=True)
    (OUT / "ocp_formulations.json").write_text(json.dumps({"machine": platform.machine(), "casadi": ca.__version__,
                                                           "rows": rows}, indent=2))
    lines = [f"# Mode-I-like OCP with IPOPT, no code generation (casadi {ca.__version__}, {platform.machine()})", "",
             f"N = {N}, dt = {DT} s, RK4, 20 states, 12 inputs, wall distance constraints. Solves 2 and 3 are "
             "warm-started from the previous solution.", "",
             "| graph | Hessian | build [s] | solve 1 [s] (iter) | solve 2 [s] (iter) | solve 3 [s] (iter) |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        cells = " | ".join(f"{s['seconds']:.2f} ({s['iterations']})" for s in r["solves"])
        lines.append(f"| {r['graph']} | {r['hessian']} | {r['build_seconds']:.1f} | {cells} |")
    (OUT / "ocp_formulations.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    from validation import manifest

    with manifest.recorded(Path(__file__).parent / "results" / "ocp_formulations.manifest.json"):
        main()
