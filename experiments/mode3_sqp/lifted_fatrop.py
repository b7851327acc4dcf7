"""A StageProblem for fatrop (CasADi's nlpsol plugin). fatrop wants explicit gap-closing rows
x_k+1 - F(x_k, u_k) = 0 with an identity on x_k+1; the stage problems' dynamics are implicit in
(x_k, v_k, x_k+1). Lifted: stage k's controls are (v_k, y_k) with y_k a copy of x_k+1, the gap
rows x_k+1 - y_k = 0, and every stage constraint a path constraint of (x_k, v_k, y_k), the stage
vector the compiled functions already take. The derivatives are the compiled stage functions',
handed to fatrop through the solver's function cache (its own options take none)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from controller.stage_nlp import StageProblem, stage_functions


class LiftedFatrop:
    def __init__(self, pr: StageProblem, name: str, fatrop_options: dict) -> None:
        self.pr = pr
        nx, nv, N, nt, nf, nc = pr.nx, pr.nv, pr.horizon, pr.n_terminal, pr.nf, pr.nc
        ns = 2 * nx + nv  # a lifted stage's block (x_k, v_k, y_k) is a stage vector
        nw = N * ns + nx
        fn = stage_functions(pr, name)
        w, P = ca.MX.sym("w", nw), ca.MX.sym("P", pr.n_p)
        S = ca.horzcat(*[w[k * ns:(k + 1) * ns] for k in range(N)])
        Pk = ca.vertcat(ca.repmat(P[:pr.np], 1, N), ca.reshape(P[pr.np:], pr.np_stage, N))
        xN, Pg = w[N * ns:], P[:pr.np]
        c, jac = fn[f"{name}_jac"].map(N)(S, Pk)
        g, jac_rows, self.stage_rows, row = [], [], [], 0

        def place(block: ca.MX, col: int) -> ca.MX:
            return ca.horzcat(ca.MX(block.size1(), col), block, ca.MX(block.size1(), nw - col - block.size2()))

        for k in range(N):
            g.append(w[(k + 1) * ns:(k + 1) * ns + nx] - w[k * ns + nx + nv:(k + 1) * ns])
            jac_rows.append(place(ca.horzcat(-ca.MX.eye(nx), ca.MX.eye(nx)), k * ns + nx + nv))
            row += nx
            if k == 0:
                g.append(w[:nf] - P[:nf])
                jac_rows.append(place(ca.MX.eye(nf), 0))
                row += nf
            g.append(c[:, k])
            jac_rows.append(place(jac[:, k * ns:(k + 1) * ns], k * ns))
            self.stage_rows.append(np.arange(row, row + nc))
            row += nc
        tc, tjac = fn[f"{name}_tjac"](xN, Pg)
        if nt:
            g.append(tc)
            jac_rows.append(place(tjac, N * ns))
        self.terminal_rows, self.ng = np.arange(row, row + nt), row + nt
        G, Jg = ca.vertcat(*g), ca.vertcat(*jac_rows)
        _, grads = fn[f"{name}_grad"].map(N)(S, Pk)
        _, tgrad = fn[f"{name}_tgrad"](xN, Pg)
        grad = ca.vertcat(ca.vec(grads), tgrad)
        lf, lg = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", self.ng)
        L = ca.horzcat(*[lg[r.tolist()] for r in self.stage_rows])
        hs = fn[f"{name}_hess"].map(N)(S, Pk, lf, L)
        th = fn[f"{name}_thess"](xN, Pg, lf, lg[self.terminal_rows.tolist()])
        hess = ca.diagcat(*[hs[:, k * ns:(k + 1) * ns] for k in range(N)], th)
        cache = {
            "nlp_jac_g": ca.Function("nlp_jac_g", [w, P], [G, Jg], ["x", "p"], ["g", "jac_g_x"]),
            "nlp_grad_f": ca.Function("nlp_grad_f", [w, P], [grad], ["x", "p"], ["grad_f_x"]),
            "nlp_hess_l": ca.Function("nlp_hess_l", [w, P, lf, lg], [lf * grad + ca.mtimes(Jg.T, lg), hess],
                                      ["x", "p", "lam_f", "lam_g"], ["grad_gamma_x", "hess_gamma_x_x"]),
        }
        f = ca.sum2(pr.cost.map(N)(S, Pk)) + (pr.terminal_cost(xN, Pg) if pr.terminal_cost is not None else 0)
        self.solver = ca.nlpsol(f"{name}_fatrop", "fatrop", {"x": w, "p": P, "f": f, "g": G}, {
            "print_time": False, "cache": cache, "structure_detection": "manual", "N": N, "nx": [nx] * (N + 1),
            "nu": [nv + nx] * N + [0], "ng": [nf + nc] + [nc] * (N - 1) + [nt], "fatrop": fatrop_options})
        nz = nx + nv
        self._keep = np.concatenate([k * ns + np.arange(nz) for k in range(N)] + [N * ns + np.arange(nx)])
        self._copy = np.concatenate([k * ns + nz + np.arange(nx) for k in range(N)])  # y_k in the lifted w
        self._next = np.concatenate([(k + 1) * nz + np.arange(nx) for k in range(N)])  # x_k+1 in the stage w

    def solve(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray, lbg: np.ndarray,
              ubg: np.ndarray) -> tuple[np.ndarray, dict]:
        """The stage problem's solution from w0 (its layout and bounds; lbg/ubg with the x_0 rows
        first, as stage_nlp.build_solver's), and fatrop's stats."""
        pr, nf, nc = self.pr, self.pr.nf, self.pr.nc
        wl = np.zeros(self.pr.horizon * (2 * pr.nx + pr.nv) + pr.nx)
        lo, hi = np.full_like(wl, -np.inf), np.full_like(wl, np.inf)
        wl[self._keep], lo[self._keep], hi[self._keep] = w0, lbw, ubw
        wl[self._copy] = w0[self._next]
        glo, ghi = np.zeros(self.ng), np.zeros(self.ng)
        glo[pr.nx:pr.nx + nf], ghi[pr.nx:pr.nx + nf] = lbg[:nf], ubg[:nf]
        for k, rows in enumerate(self.stage_rows):
            glo[rows], ghi[rows] = lbg[nf + k * nc:nf + (k + 1) * nc], ubg[nf + k * nc:nf + (k + 1) * nc]
        glo[self.terminal_rows], ghi[self.terminal_rows] = lbg[nf + len(self.stage_rows) * nc:], \
            ubg[nf + len(self.stage_rows) * nc:]
        r = self.solver(x0=np.clip(wl, lo, hi), p=p, lbx=lo, ubx=hi, lbg=glo, ubg=ghi)
        return np.asarray(r["x"]).ravel()[self._keep], self.solver.stats()
