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

import hashlib
import os
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

CACHE = Path(os.environ.get("UVMS_CODEGEN_CACHE", Path.home() / ".cache" / "uvms-codegen"))


@dataclass(frozen=True)
class StageProblem:
    """min sum_k cost(s_k, p) s.t. x_0 = p[:nx], lbc <= constraints(s_k, p) <= ubc, bounds on w.

    `cost` and `constraints` are SX functions of (s, p) with s = (x_k, v_k, x_k+1) (2 nx + nv)."""

    nx: int
    nv: int
    horizon: int
    np: int
    cost: ca.Function
    constraints: ca.Function

    @property
    def nc(self) -> int:
        return self.constraints.size1_out(0)

    @property
    def n_w(self) -> int:
        return self.horizon * (self.nx + self.nv) + self.nx


def compiled(functions: list[ca.Function], name: str) -> dict[str, ca.Function]:
    """The functions compiled to one shared object (gcc -O1), cached by a hash of their C code."""
    gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    for f in functions:
        gen.add(f)
    with tempfile.TemporaryDirectory() as tmp:
        cwd = os.getcwd()
        os.chdir(tmp)
        try:
            gen.generate()
            source = Path(tmp, f"{name}.c").read_bytes()
        finally:
            os.chdir(cwd)
    key = hashlib.sha256(source).hexdigest()[:16]
    CACHE.mkdir(parents=True, exist_ok=True)
    so = CACHE / f"{name}_{key}.so"
    if not so.exists():
        c = CACHE / f"{name}_{key}.c"
        c.write_bytes(source)
        tmp_so = so.with_suffix(f".{os.getpid()}.tmp")
        subprocess.run(["gcc", "-O1", "-fPIC", "-shared", str(c), "-o", str(tmp_so)], check=True)
        tmp_so.replace(so)  # atomic: parallel runs never load a half-written file
        c.unlink()
    return {f.name(): ca.external(f.name(), str(so)) for f in functions}


def build_solver(problem: StageProblem, name: str, ipopt_options: dict) -> ca.Function:
    """IPOPT on the stage problem with compiled, block-assembled derivatives."""
    pr = problem
    nx, nv, N, nz = pr.nx, pr.nv, pr.horizon, pr.nx + pr.nv
    ns = 2 * nx + nv
    s, p = ca.SX.sym("s", ns), ca.SX.sym("p", pr.np)
    lam_f, lam_c = ca.SX.sym("lam_f"), ca.SX.sym("lam_c", pr.nc)
    c = pr.constraints(s, p)
    cost = pr.cost(s, p)
    lagrangian = lam_f * cost + ca.dot(lam_c, c)
    fns = [
        ca.Function(f"{name}_jac", [s, p], [c, ca.jacobian(c, s)]),
        ca.Function(f"{name}_grad", [s, p], [cost, ca.gradient(cost, s)]),
        ca.Function(f"{name}_hess", [s, p, lam_f, lam_c], [ca.hessian(lagrangian, s)[0]]),
    ]
    fn = compiled(fns, name)
    w, P = ca.MX.sym("w", pr.n_w), ca.MX.sym("P", pr.np)
    S = ca.horzcat(*[w[k * nz:k * nz + ns] for k in range(N)])
    Pk = ca.repmat(P, 1, N)
    # f and g through the SX functions (differentiable by CasADi, for the final multiplier pass);
    # every iteration's derivatives come from the compiled callbacks below.
    g = ca.vertcat(w[:nx] - P[:nx], ca.vec(pr.constraints.map(N)(S, Pk)))
    f = ca.sum2(pr.cost.map(N)(S, Pk))

    def place(block: ca.MX, k: int) -> ca.MX:
        """A stage block's columns placed at s_k's position in w."""
        return ca.horzcat(ca.MX(block.size1(), k * nz), block, ca.MX(block.size1(), pr.n_w - k * nz - ns))

    cs, jacs = fn[f"{name}_jac"].map(N)(S, Pk)
    jac_rows = [ca.horzcat(ca.MX.eye(nx), ca.MX(nx, pr.n_w - nx))]
    jac_rows += [place(jacs[:, k * ns:(k + 1) * ns], k) for k in range(N)]
    g_from_jac = ca.vertcat(w[:nx] - P[:nx], ca.vec(cs))
    jac_g = ca.Function("nlp_jac_g", [w, P], [g_from_jac, ca.vertcat(*jac_rows)], ["x", "p"], ["g", "jac_g_x"])
    ls, grads = fn[f"{name}_grad"].map(N)(S, Pk)
    grad = sum((ca.vertcat(ca.MX(k * nz, 1), grads[:, k], ca.MX(pr.n_w - k * nz - ns, 1)) for k in range(N)),
               ca.MX(pr.n_w, 1))
    grad_f = ca.Function("nlp_grad_f", [w, P], [ca.sum2(ls), grad], ["x", "p"], ["f", "grad_f_x"])
    lf, lg = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", nx + N * pr.nc)
    L = ca.reshape(lg[nx:], pr.nc, N)
    hs = fn[f"{name}_hess"].map(N)(S, Pk, lf, L)
    hess = sum((ca.diagcat(ca.MX(k * nz, k * nz), hs[:, k * ns:(k + 1) * ns], ca.MX(pr.n_w - k * nz - ns,
                                                                                    pr.n_w - k * nz - ns))
                for k in range(N)), ca.MX(pr.n_w, pr.n_w))
    hess_lag = ca.Function("nlp_hess_l", [w, P, lf, lg], [ca.triu(hess)], ["x", "p", "lam_f", "lam_g"],
                           ["triu_hess_gamma_x_x"])
    return ca.nlpsol(name, "ipopt", {"x": w, "p": P, "f": f, "g": g},
                     {"jac_g": jac_g, "grad_f": grad_f, "hess_lag": hess_lag, "print_time": False,
                      "ipopt": ipopt_options})
