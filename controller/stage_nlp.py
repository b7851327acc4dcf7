"""Stage-structured NLPs with compiled per-stage derivatives, for IPOPT.

An OCP in multiple-shooting form has variables w = [x_0, v_0, x_1, v_1, ..., x_N] (state x, stage
variables v such as inputs and accelerations) and per-stage functions of s_k = (x_k, v_k, x_k+1)
(contiguous in w). Expanding the whole NLP into one SX graph gives derivatives too large to compile
(millions of nodes for the UVMS); CasADi's MX derivatives of mapped calls are ~10x slower than that.
Here the per-stage constraint Jacobian and Lagrangian Hessian are derived once in SX, compiled to C
(gcc -O1, cached on disk by a hash of the generated code) and assembled into IPOPT's sparse
`jac_g` and `hess_lag` callbacks, whose block structure is known.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass

import casadi as ca

from controller.codegen import compiled_lazily


@dataclass(frozen=True)
class StageProblem:
    """min sum_k cost(s_k, p_k) + terminal_cost(x_N, p) s.t. x_0[:nf] = p[:nf], constraints(s_k, p_k) and
    terminal_constraints(x_N, p) within bounds, bounds on w.

    `cost` and `constraints` are SX functions of (s, p_k) with s = (x_k, v_k, x_k+1) (2 nx + nv) and
    p_k = (p, stage parameters of stage k); the NLP's parameter vector is (p, stage parameters of
    stages 0..N-1), np + N np_stage long. The terminal functions take (x_N, p)."""

    nx: int
    nv: int
    horizon: int
    np: int
    cost: ca.Function
    constraints: ca.Function
    terminal_cost: ca.Function | None = None
    terminal_constraints: ca.Function | None = None
    np_stage: int = 0
    n_fixed: int | None = None  # how many leading entries of x_0 equal p (None: all nx)

    @property
    def nc(self) -> int:
        return self.constraints.size1_out(0)

    @property
    def nf(self) -> int:
        return self.nx if self.n_fixed is None else self.n_fixed

    @property
    def n_terminal(self) -> int:
        return self.terminal_constraints.size1_out(0) if self.terminal_constraints is not None else 0

    @property
    def n_p(self) -> int:
        return self.np + self.horizon * self.np_stage

    @property
    def n_w(self) -> int:
        return self.horizon * (self.nx + self.nv) + self.nx

def stage_functions(problem: StageProblem, name: str) -> dict[str, ca.Function]:
    """The per-stage and terminal functions, compiled and cached (controller.codegen.compiled_lazily:
    derived only when the cache lacks them): {name}_g (c), _jac (c, dc/ds), _grad (cost, its
    gradient), _hess (Hessian of lam_f cost + lam_c.c in s) and the terminal _tg, _tjac, _tgrad,
    _thess. The code depends on the stage and terminal functions only, not on the horizon: problems
    that differ in N alone share one shared object (Mode II's variable horizon)."""
    pr = problem
    names = [f"{name}_{s}" for s in ("g", "jac", "grad", "hess", "tg", "tjac", "tgrad", "thess")]
    sources = [f for f in (pr.cost, pr.constraints, pr.terminal_cost, pr.terminal_constraints) if f is not None]
    shape = f"nx={pr.nx} nv={pr.nv} np={pr.np} np_stage={pr.np_stage}"
    return compiled_lazily(name, names, sources, lambda: _derive(pr, name),
                           recipe=shape + inspect.getsource(_derive))


def _derive(pr: StageProblem, name: str) -> list[ca.Function]:
    """stage_functions' functions, derived symbolically (SX)."""
    nx, nv = pr.nx, pr.nv
    ns, npk = 2 * nx + nv, pr.np + pr.np_stage
    s, p, x, pg = ca.SX.sym("s", ns), ca.SX.sym("p", npk), ca.SX.sym("x", nx), ca.SX.sym("pg", pr.np)
    lam_f, lam_c = ca.SX.sym("lam_f"), ca.SX.sym("lam_c", pr.nc)
    c = pr.constraints(s, p)
    cost = pr.cost(s, p)
    fns = [
        ca.Function(f"{name}_g", [s, p], [c]),
        ca.Function(f"{name}_jac", [s, p], [c, ca.jacobian(c, s)]),
        ca.Function(f"{name}_grad", [s, p], [cost, ca.gradient(cost, s)]),
        ca.Function(f"{name}_hess", [s, p, lam_f, lam_c], [ca.hessian(lam_f * cost + ca.dot(lam_c, c), s)[0]]),
    ]
    nt = pr.n_terminal
    tc = pr.terminal_constraints(x, pg) if nt else ca.SX.zeros(0)
    tf = pr.terminal_cost(x, pg) if pr.terminal_cost is not None else ca.SX(0)
    lam_t = ca.SX.sym("lam_t", nt)
    fns += [
        ca.Function(f"{name}_tg", [x, pg], [tc]),
        ca.Function(f"{name}_tjac", [x, pg], [tc, ca.jacobian(tc, x)]),
        ca.Function(f"{name}_tgrad", [x, pg], [tf, ca.gradient(tf, x)]),
        ca.Function(f"{name}_thess", [x, pg, lam_f, lam_t], [ca.hessian(lam_f * tf + ca.dot(lam_t, tc), x)[0]]),
    ]
    return fns


def build_solver(problem: StageProblem, name: str, ipopt_options: dict,
                 functions: dict[str, ca.Function] | None = None, options: dict | None = None) -> ca.Function:
    """IPOPT on the stage problem with compiled, block-assembled derivatives: `functions` from
    `stage_functions` (derived here when not given; deriving them costs about 1 s, assembling the
    NLP from them about 10 ms). `options`: more of nlpsol's options (e.g. an iteration_callback)."""
    pr = problem
    nx, nv, N, nz = pr.nx, pr.nv, pr.horizon, pr.nx + pr.nv
    ns, nt = 2 * nx + nv, pr.n_terminal
    fn = functions if functions is not None else stage_functions(pr, name)
    w, P = ca.MX.sym("w", pr.n_w), ca.MX.sym("P", pr.n_p)
    S = ca.horzcat(*[w[k * nz:k * nz + ns] for k in range(N)])
    Pk = ca.vertcat(ca.repmat(P[:pr.np], 1, N), ca.reshape(P[pr.np:], pr.np_stage, N))
    xN = w[N * nz:]
    # g through the compiled stage functions too (the SX map evaluated interpreted took 1 ms a
    # call); f through the SX functions (cheap). CasADi never differentiates them: every
    # derivative comes from the compiled callbacks below (and calc_lam_p is off).
    g = ca.vertcat(w[:pr.nf] - P[:pr.nf], ca.vec(fn[f"{name}_g"].map(N)(S, Pk)),
                   fn[f"{name}_tg"](xN, P[:pr.np]) if nt else ca.MX(0, 1))
    f = ca.sum2(pr.cost.map(N)(S, Pk)) + (pr.terminal_cost(xN, P[:pr.np]) if pr.terminal_cost is not None else 0)

    def place(block: ca.MX, k: int, width: int) -> ca.MX:
        """A block's columns placed at w[k nz : k nz + width]."""
        return ca.horzcat(ca.MX(block.size1(), k * nz), block, ca.MX(block.size1(), pr.n_w - k * nz - width))

    cs, jacs = fn[f"{name}_jac"].map(N)(S, Pk)
    tcs, tjac = fn[f"{name}_tjac"](xN, P[:pr.np])
    jac_rows = [ca.horzcat(ca.MX.eye(pr.nf), ca.MX(pr.nf, pr.n_w - pr.nf))]
    jac_rows += [place(jacs[:, k * ns:(k + 1) * ns], k, ns) for k in range(N)]
    if nt:
        jac_rows.append(place(tjac, N, nx))
    g_from_jac = ca.vertcat(w[:pr.nf] - P[:pr.nf], ca.vec(cs), tcs)
    jac_g = ca.Function("nlp_jac_g", [w, P], [g_from_jac, ca.vertcat(*jac_rows)], ["x", "p"], ["g", "jac_g_x"])
    ls, grads = fn[f"{name}_grad"].map(N)(S, Pk)
    tl, tgrad = fn[f"{name}_tgrad"](xN, P[:pr.np])
    grad = sum((ca.vertcat(ca.MX(k * nz, 1), grads[:, k], ca.MX(pr.n_w - k * nz - ns, 1)) for k in range(N)),
               ca.vertcat(ca.MX(N * nz, 1), tgrad))
    grad_f = ca.Function("nlp_grad_f", [w, P], [ca.sum2(ls) + tl, grad], ["x", "p"], ["f", "grad_f_x"])
    nf = pr.nf
    lf, lg = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", nf + N * pr.nc + nt)
    L = ca.reshape(lg[nf:nf + N * pr.nc], pr.nc, N)
    hs = fn[f"{name}_hess"].map(N)(S, Pk, lf, L)
    th = fn[f"{name}_thess"](xN, P[:pr.np], lf, lg[nf + N * pr.nc:])
    hess = sum((ca.diagcat(ca.MX(k * nz, k * nz), hs[:, k * ns:(k + 1) * ns], ca.MX(pr.n_w - k * nz - ns,
                                                                                    pr.n_w - k * nz - ns))
                for k in range(N)), ca.diagcat(ca.MX(N * nz, N * nz), th))
    hess_lag = ca.Function("nlp_hess_l", [w, P, lf, lg], [ca.triu(hess)], ["x", "p", "lam_f", "lam_g"],
                           ["triu_hess_gamma_x_x"])
    return ca.nlpsol(name, "ipopt", {"x": w, "p": P, "f": f, "g": g},
                     {"jac_g": jac_g, "grad_f": grad_f, "hess_lag": hess_lag, "print_time": False, "calc_lam_p": False,
                      "calc_lam_x": False, "ipopt": ipopt_options, **(options or {})})
