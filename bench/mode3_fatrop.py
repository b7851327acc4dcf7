"""Mode III on fatrop (the structure-exploiting interior point that ships with CasADi) against the
default IPOPT, on the Mode III problems that MuJoCo closed loops posed.

  python bench/mode3_solvers.py --record 2   # once: out/mode3_problems.npz (about 1 min)
  python bench/mode3_fatrop.py               # about 2 min (plus compiling, once); writes
                                             # bench/results/mode3_fatrop.md

fatrop wants explicit dynamics, x_k+1 = f(x_k, u_k), and path constraints on (x_k, u_k) alone; Mode
III's midpoint rule is implicit in h_k+1 (controller.transcription.midpoint_residual: the kinematics
at the midpoint state). Here it is made explicit without changing its solutions: the midpoint's
Euler angles e_m become three more controls, so that h_k+1 = (p_k + dt R(e_m) v_m, 2 e_m - e_k,
q_k + dt qdot_m, nu_k + dt a_k) with nu_m = nu_k + dt a_k / 2, and the angle rows
e_m - e_k - dt/2 E(e_m) omega_m = 0 join the path constraints, with the inverse dynamics, the tip on
the plane, friction and the clearances (all evaluated at h_k+1 = f(x_k, u_k)). The cost and the
constraints are J_III's and Mode III's (controller.mode3), with their settings. Derivatives: the
same per-stage compiled functions as IPOPT's (controller.stage_nlp), handed to CasADi's fatrop
interface through its function cache (`nlp_jac_g`, `nlp_grad_f`, `nlp_hess_l`).

Both start from the same primal guess; IPOPT also gets the warm start's multipliers, as in the
closed loop (CasADi's fatrop interface takes no initial multipliers). fatrop stops at tolerance 1e-6
or after 3 acceptable iterates (1e-2, constraints 1e-5), IPOPT as in controller.mode3. A plan is
usable when its largest constraint violation is below 1e-5 (m, N, N m).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np
from mode3_solvers import load_problems
from tqdm import tqdm

from controller.codegen import compiled
from controller.kinematics import euler_rates, euler_zyx
from controller.mode3 import ModeIIIOCP, ModeIIISettings, friction_rows, stage_cost
from controller.stage_nlp import StageProblem, stage_functions
from controller.transcription import clearances, tip_gap

OUT = Path(__file__).parent / "results"
USABLE = 1e-5  # largest constraint violation of a usable plan
FATROP = {"print_level": 0, "max_iter": 200, "tol": 1e-6, "tol_acceptable": 1e-2, "acceptable_iter": 3,
          "constr_viol_tol": 1e-5, "mu_init": 1e-3}


class FatropModeIII:
    """Mode III's OCP (the same cost, constraints and settings as `ocp`) in fatrop's stage form."""

    def __init__(self, ocp: ModeIIIOCP, options: dict = FATROP):
        self.ocp, model, s, N = ocp, ocp.model, ocp.settings, ocp.settings.horizon
        ns, nu, nv, n = model.n_states, model.n_inputs, model.n_speeds, model.n_joints
        plane = ocp.planes[ocp.contact]
        h, u, a, F, em = (ca.SX.sym(k, m) for k, m in (("h", ns), ("u", nu), ("a", nv), ("F", 3), ("em", 3)))
        x1, P = ca.SX.sym("x1", ns), ca.SX.sym("P", ns + 4)  # h0, current, stage weight
        vc, wi = P[ns:ns + 3], P[ns + 3]
        vm = h[nv:] + s.dt / 2 * a
        h1 = ca.vertcat(h[:3] + s.dt * euler_zyx(em[0], em[1], em[2]) @ vm[:3], 2 * em - h[3:6],
                        h[6:6 + n] + s.dt * vm[6:], h[nv:] + s.dt * a)
        hm = (h + h1) / 2
        Fw = ca.vertcat(F, ca.SX.zeros(3))
        Q = sum(model.generalized_forces(hm, u, Fw, ca.DM(ocp.Rw), vc, ca.DM.zeros(3)))
        path = ca.vertcat(
            h1[3:6] - h[3:6] - s.dt * euler_rates(em, vm[3:6]),
            model.mass_matrix(hm) @ a - Q,
            tip_gap(model, h1, plane),
            friction_rows(model, ocp.Rw, hm, F, s),
            clearances(model, h1, ocp.planes, ocp.contact),
        )
        cost = stage_cost(model, plane, h1, u, F, wi, s)
        self.nvv, ng = nu + nv + 6, path.size1()
        st = ca.vertcat(h, u, a, F, em, x1)
        pr = StageProblem(nx=ns, nv=self.nvv, horizon=N, np=ns + 3, np_stage=1,
                          cost=ca.Function("cost3f", [st, P], [cost]),
                          constraints=ca.Function("cons3f", [st, P], [ca.vertcat(x1 - h1, path)]))
        name = f"mode3fatrop_{model.params.name}_{model.params.arm.name}_{plane.name}"
        fn = stage_functions(pr, name)
        nz, nst = ns + self.nvv, 2 * ns + self.nvv
        # the Lagrangian's gradient (in s) and Hessian (in (x_k, u_k): x_k+1 enters linearly), per stage
        ss, pp, lf_s, lc_s = ca.SX.sym("s", nst), ca.SX.sym("p", ns + 4), ca.SX.sym("lf"), ca.SX.sym("lc", pr.nc)
        lag = lf_s * pr.cost(ss, pp) + ca.dot(lc_s, pr.constraints(ss, pp))
        hess, grad = ca.hessian(lag, ss)
        lagf = compiled([ca.Function(f"{name}_lag", [ss, pp, lf_s, lc_s], [grad, hess[:nz, :nz]])],
                        f"{name}_lag")[f"{name}_lag"]
        w, Pw = ca.MX.sym("w", pr.n_w), ca.MX.sym("P", pr.n_p)
        S = ca.horzcat(*[w[k * nz:k * nz + nst] for k in range(N)])
        Pk = ca.vertcat(ca.repmat(Pw[:pr.np], 1, N), ca.reshape(Pw[pr.np:], 1, N))

        def spread(cols: ca.MX) -> ca.MX:
            """Per-stage vectors in s (columns) summed into a vector in w."""
            return sum((ca.vertcat(ca.MX(k * nz, 1), cols[:, k], ca.MX(pr.n_w - k * nz - nst, 1)) for k in range(N)),
                       ca.MX(pr.n_w, 1))

        cs, jacs = fn[f"{name}_jac"].map(N)(S, Pk)
        J = ca.vertcat(*[ca.horzcat(ca.MX(pr.nc, k * nz), jacs[:, k * nst:(k + 1) * nst],
                                    ca.MX(pr.nc, pr.n_w - k * nz - nst)) for k in range(N)])
        lf, lg = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", N * pr.nc)
        gk, hk = lagf.map(N)(S, Pk, lf, ca.reshape(lg, pr.nc, N))
        cache = {
            "nlp_jac_g": ca.Function("nlp_jac_g", [w, Pw], [ca.vec(cs), J], ["x", "p"], ["g", "jac_g_x"]),
            "nlp_grad_f": ca.Function("nlp_grad_f", [w, Pw], [spread(fn[f"{name}_grad"].map(N)(S, Pk)[1])],
                                      ["x", "p"], ["grad_f_x"]),
            "nlp_hess_l": ca.Function("nlp_hess_l", [w, Pw, lf, lg],
                                      [spread(gk), ca.diagcat(*[hk[:, k * nz:(k + 1) * nz] for k in range(N)],
                                                              ca.MX(ns, ns))],
                                      ["x", "p", "lam_f", "lam_g"], ["grad_gamma_x", "hess_gamma_x_x"]),
        }
        f = ca.sum2(pr.cost.map(N)(S, Pk))
        g = ca.vec(fn[f"{name}_g"].map(N)(S, Pk))
        self.solver = ca.nlpsol(name, "fatrop", {"x": w, "p": Pw, "f": f, "g": g}, {
            "structure_detection": "manual", "N": N, "nx": [ns] * (N + 1), "nu": [self.nvv] * N + [0],
            "ng": [ng] * N + [0], "fatrop": options, "print_time": False, "cache": cache})
        self.lbg, self.ubg = np.zeros(N * pr.nc), np.zeros(N * pr.nc)
        for k in range(N):
            i = (k + 1) * pr.nc - ocp.n_clear
            self.lbg[i:i + ocp.n_clear], self.ubg[i:i + ocp.n_clear] = s.distance_margin, np.inf

    def solve(self, h0: np.ndarray, guess: np.ndarray, current: np.ndarray) -> tuple[bool, int, float, float, dict]:
        """(usable, iterations, wall time [s], cost, fatrop's timing statistics) from Mode III's primal
        guess (its layout: controller.mode3), h_0 fixed by its bounds."""
        ocp, N, nz = self.ocp, self.ocp.settings.horizon, self.ocp.nz
        lbw, ubw = ocp.bounds()
        guess = np.clip(guess, lbw, ubw)
        hs = ocp.unpack(guess)[0]
        x0, lb, ub = [], [], []
        for k in range(N):
            x0 += [guess[k * nz:(k + 1) * nz], (hs[k, 3:6] + hs[k + 1, 3:6]) / 2]
            lb += [lbw[k * nz:(k + 1) * nz], np.full(3, -np.inf)]
            ub += [ubw[k * nz:(k + 1) * nz], np.full(3, np.inf)]
        x0, lb, ub = (np.concatenate([*v, e[N * nz:]]) for v, e in ((x0, guess), (lb, lbw), (ub, ubw)))
        lb[:ocp.ns] = ub[:ocp.ns] = h0
        P = np.concatenate([h0, current, ocp.weights])
        t0 = time.perf_counter()
        r = self.solver(x0=x0, p=P, lbx=lb, ubx=ub, lbg=self.lbg, ubg=self.ubg)
        elapsed = time.perf_counter() - t0
        st = self.solver.stats()
        gv = np.asarray(r["g"]).ravel()
        violation = max(float(np.max(self.lbg - gv)), float(np.max(gv - self.ubg)), 0.0)
        return violation < USABLE, int(st["iter_count"]), elapsed, float(r["f"]), st["fatrop"]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--every", type=int, default=1, metavar="K", help="every K-th problem only (a quick look)")
    every = ap.parse_args(argv).every
    if every < 1:
        raise SystemExit(f"--every {every}; allowed: >= 1")
    data, cold, model, scene = load_problems()
    n = len(cold)
    ocps: dict[int, tuple[ModeIIIOCP, FatropModeIII]] = {}
    rows = []
    for i in tqdm(range(0, n, every), desc="problems", unit="problem"):
        contact = int(data["contact"][i])
        if contact not in ocps:
            ocp = ModeIIIOCP(model, scene.planes, contact, ModeIIISettings())
            ocps[contact] = ocp, FatropModeIII(ocp)
        ocp, fat = ocps[contact]
        ocp.limit_inputs(data["lo"][i], data["hi"][i])
        duals = None if cold[i] else (data["lam_g"][i], data["lam_x"][i])
        ref = ocp.solve(data["h0"][i], data["guess"][i], data["current"][i], duals)
        ok, it, t, cost, stats = fat.solve(data["h0"][i], data["guess"][i], data["current"][i])
        rows.append((ref.status.usable, ref.iterations, ref.solve_time, ref.cost, ok, it, t, cost,
                     stats["compute_sd_time"], stats["eval_hess_time"], stats["time_total"]))
    a = np.array(rows, float)
    cold = cold[::every]
    n, warm = len(cold), ~cold

    def mp(v: np.ndarray, scale: float = 1.0) -> str:
        return f"{scale * np.median(v):.0f} / {scale * np.percentile(v, 95):.0f}" if len(v) else "-"

    both = (a[:, 0] > 0) & (a[:, 4] > 0)

    def per(col: int) -> float:
        """fatrop's timer `col`, ms per fatrop iteration."""
        return 1e3 * a[:, col].sum() / a[:, 5].sum()

    lines = [
        "# Mode III: fatrop against IPOPT on recorded problems", "",
        f"`python bench/mode3_fatrop.py` ({platform.machine()}, casadi {ca.__version__}; the problems of "
        "`bench/mode3_solvers.py --record 2`: "
        f"{n} Mode III problems, {int(cold.sum())} cold starts from Algorithm 2's guess). Side by side in one run, "
        "each problem solved by both. Median / p95 over the problems.", "",
        "| solver | usable | iterations, warm | iterations, cold | time, warm [ms] | ms per iteration |",
        "|---|---|---|---|---|---|",
        f"| IPOPT (MUMPS), the default, with the warm start's multipliers | {int(a[:, 0].sum())}/{n} | "
        f"{mp(a[warm, 1])} | {mp(a[cold, 1])} | {mp(a[warm, 2], 1e3)} | {1e3 * a[:, 2].sum() / a[:, 1].sum():.1f} |",
        f"| fatrop, explicit midpoint transcription, primal warm start | {int(a[:, 4].sum())}/{n} | "
        f"{mp(a[warm, 5])} | {mp(a[cold, 5])} | {mp(a[warm, 6], 1e3)} | {1e3 * a[:, 6].sum() / a[:, 5].sum():.1f} |",
        "",
        f"fatrop's own timers, per iteration: search direction (Riccati) {per(8):.2f} ms, Hessian evaluation "
        f"{per(9):.2f} ms, its whole algorithm {per(10):.2f} ms; outside them (CasADi's interface creates and frees "
        f"the solver at every call) {1e3 * np.median(a[:, 6] - a[:, 10]):.0f} ms per solve (median). On the problems "
        f"both solve, fatrop's cost minus IPOPT's: median {np.median(a[both, 7] - a[both, 3]):+.1e}; fatrop faster "
        f"on {int((a[both, 6] < a[both, 2]).sum())} of {int(both.sum())}; median time ratio IPOPT / fatrop "
        f"{np.median(a[both, 2] / a[both, 6]):.2f}.",
    ]
    (OUT / "mode3_fatrop.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main(sys.argv[1:])
