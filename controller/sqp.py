"""Sequential quadratic programming for stage problems with implicit dynamics: Gauss-Newton
Hessian, one structure-exploiting QP (HPIPM's Riccati interior point, through CasADi's `conic`)
per iteration, the compiled stage derivatives of `controller.stage_nlp`.

The stage problem's constraints begin with the implicit dynamics: nx + n_alg equality rows in
(x_k, u_k, z_k, x_k+1), where the last n_alg stage variables z_k are algebraic (Mode I: the
accelerations of the inverse-dynamics midpoint rule) and carry no bounds. HPIPM wants explicit
dynamics x_k+1 = A x_k + B u_k + b, so each iteration eliminates (dx_k+1, dz_k) stage by stage
from the linearized dynamics by the implicit function theorem (as implicit integrators do for
acados): [dx_k+1; dz_k] = T_k [dx_k; du_k; 1] with T_k = -[R_x1 R_z]^-1 [R_x R_u r]. The stage's
remaining constraints and its cost are rewritten on (dx_k, du_k) through T_k, exactly (the QP is
the linearization, nothing more is dropped). The Hessian is the cost's own (Gauss-Newton: the
constraints' curvature is left out), so with Mode I's quadratic cost it is constant and always
positive semidefinite; a fixed point of the iteration is a KKT point of the NLP.

Globalization: by default none, full steps; the warm start from the shifted previous plan keeps
them in the region of full-step convergence far from the obstacles. With `line_search` each step
is cut by Armijo backtracking on the L1 merit function f + mu |c|_1 (mu at least 1.5 times the
QP's largest multiplier, and large enough that the step descends: Nocedal and Wright, eq. 18.36):
near a wall, where the clearance rows bend within one step, full steps leave the dynamics violated
by tens of newtons after 16 iterations, cut ones reach a re-simulated feasible plan in 1 to 5
(docs/decisions.md, 'The fresh plan continued before the minimum-violation problem'). A caller's
`stop` test, given the iterate after each iteration, ends the solve as STOPPED.

Converged (SUCCESS): the step's largest entry below `step_tol` and the constraint violation below
`violation_tol`. At `max_iter` the iterate is FEASIBLE when its
violation is below FEASIBLE_VIOLATION, else REAL_TIME when `real_time` is set (with max_iter = 1 the
real-time iteration of Diehl, Bock and Schloeder 2005: one QP per control period, converging over
the periods), else MAX_ITER. A failed QP is FAILED; the caller falls back (controller.switching).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import casadi as ca
import numpy as np

from controller.codegen import NumpyCall
from controller.stage_nlp import StageProblem, stage_functions
from controller.transcription import FEASIBLE_VIOLATION, SolverStatus


class QPMode(Enum):
    """HPIPM's presets. SPEED_ABS exits on the barrier parameter alone (no residuals computed): on
    Mode I's closed loop 7 interior-point iterations per QP against ROBUST's 11, 2.3 ms against
    4.2 ms; its steps are accurate to about qp_tol, so an SQP iterated to convergence on them stops
    within about that of the KKT point (tests/test_mode1.py iterates on ROBUST's)."""

    SPEED_ABS = "speed_abs"
    SPEED = "speed"
    BALANCE = "balance"
    ROBUST = "robust"


@dataclass(frozen=True)
class SQPSettings:
    max_iter: int = 2  # SQP iterations per solve (1: the real-time iteration; see bench/results/nmpc_modes.md)
    real_time: bool = True  # at max_iter, a successful last QP gives a usable REAL_TIME iterate
    step_tol: float = 1e-3  # largest |step| entry at convergence (m, rad, m/s, N...)
    violation_tol: float = 1e-6  # largest constraint violation at convergence (m, N, N m)
    qp_iter_max: int = 50  # HPIPM interior-point iterations
    qp_mode: QPMode = QPMode.ROBUST
    qp_tol: float = 1e-6  # HPIPM's tolerances (ROBUST at 1e-8 and SPEED_ABS at 1e-9 stall at the iteration cap)
    qp_mu0: float | None = 0.1  # HPIPM's initial barrier parameter (None: the mode's own; ROBUST's is 100)
    line_search: bool = False  # Armijo backtracking on the L1 merit function (False: full steps)


ARMIJO = 1e-4  # the merit's sufficient decrease, as a fraction of its directional derivative
SHORTEST = 1 / 64  # the shortest step fraction tried; taken when no longer one decreases the merit


@dataclass(frozen=True)
class SQPResult:
    status: SolverStatus
    w: np.ndarray  # primal solution, the stage problem's layout
    iterations: int
    qp_iterations: int  # summed over the SQP iterations
    violation: float  # largest constraint violation at w
    cost: float
    solve_time: float  # s


def _block_sparsity(shape: tuple[int, int], blocks: list[tuple[int, int, int, int]],
                    diagonal: list[tuple[int, int, int]] = ()) -> tuple[ca.Sparsity, tuple]:
    """The sparsity of dense blocks (row, col, rows, cols) and diagonal blocks (row, col, size),
    and its nonzeros' (rows, cols) in CasADi's column-major order (to gather values from a dense
    numpy matrix)."""
    rows, cols = [], []
    for r, c, nr, nc in blocks:
        rr, cc = np.meshgrid(np.arange(r, r + nr), np.arange(c, c + nc), indexing="ij")
        rows.append(rr.ravel())
        cols.append(cc.ravel())
    for r, c, n in diagonal:
        rows.append(np.arange(r, r + n))
        cols.append(np.arange(c, c + n))
    sp = ca.Sparsity.triplet(*shape, np.concatenate(rows).tolist(), np.concatenate(cols).tolist())
    r, c = sp.get_triplet()
    return sp, (np.array(r), np.array(c))


class StageSQP:
    """SQP on `problem` (no terminal functions; x_0 fully fixed to p[:nx]). The last n_alg entries
    of each stage's v are algebraic; the first nx + n_alg constraint rows are the dynamics (= 0).
    The cost must be a separable quadratic in the states and controls (its Hessian diagonal, without
    entries on the algebraic variables; evaluated once, at the first solve)."""

    def __init__(self, problem: StageProblem, name: str, n_alg: int, settings: SQPSettings = SQPSettings()):
        pr = problem
        if pr.n_terminal or pr.terminal_cost is not None or pr.nf != pr.nx or pr.np_stage:
            raise ValueError("StageSQP: terminal functions, partly fixed x_0 and stage parameters are not supported")
        self.pr, self.settings, self.n_alg = pr, settings, n_alg
        N, nx, nv = pr.horizon, pr.nx, pr.nv
        self.nu = nv - n_alg  # the QP's controls per stage
        self.nd = nx + n_alg  # dynamics rows
        self.ng = pr.nc - self.nd  # path constraints per stage
        self.ns = 2 * nx + nv
        fn = stage_functions(pr, name)
        S, P = ca.MX.sym("S", self.ns, N), ca.MX.sym("P", pr.np)
        PN = ca.repmat(P, 1, N)
        c, J = fn[f"{name}_jac"].map(N)(S, PN)
        _, grad = fn[f"{name}_grad"].map(N)(S, PN)
        self._lin = NumpyCall(ca.Function("linearization", [S, P], [ca.densify(c), ca.densify(J), ca.densify(grad)]))
        self._val = NumpyCall(ca.Function("values", [S, P], [ca.densify(fn[f"{name}_g"].map(N)(S, PN)),
                                                            ca.sum2(pr.cost.map(N)(S, PN))]))
        hess = fn[f"{name}_hess"].map(N)(S, PN, 1.0, ca.DM.zeros(pr.nc, N))
        self._cost_hessian = NumpyCall(ca.Function("cost_hessian", [S, P], [ca.densify(hess)]))
        self._h: np.ndarray | None = None  # the cost Hessian's diagonal per stage (N, ns)
        nz = nx + nv
        self._stage_idx = (np.arange(N)[:, None] * nz + np.arange(self.ns)).ravel()  # s_k = w[k nz:k nz + ns]
        self._dep = np.r_[nz:nz + nx, nx + self.nu:nz]  # the eliminated (x_k+1, z_k) in s, in T's row order
        nq, nxu = (N + 1) * nx + N * self.nu, nx + self.nu
        na = N * (nx + self.ng)
        self._col = [k * nxu for k in range(N + 1)]  # where dx_k starts in the QP's variables
        a_blocks, a_diag, h_blocks = [], [], []
        for k in range(N):
            r = k * (nx + self.ng)
            a_blocks += [(r, self._col[k], nx, nxu), (r + nx, self._col[k], self.ng, nxu)]
            a_diag.append((r, self._col[k + 1], nx))
            h_blocks.append((self._col[k], self._col[k], nxu, nxu))
        h_blocks.append((self._col[N], self._col[N], nx, nx))
        a_sp, a_idx = _block_sparsity((na, nq), a_blocks, a_diag)
        h_sp, h_idx = _block_sparsity((nq, nq), h_blocks)
        qp = ca.conic(f"{name}_qp", "hpipm", {"a": a_sp, "h": h_sp}, {
            "N": N, "nx": [nx] * (N + 1), "nu": [self.nu] * N + [0], "ng": [self.ng] * N + [0],
            "print_problem": False, "print_time": False, "error_on_fail": False,
            "hpipm": {"mode": settings.qp_mode.value, "iter_max": settings.qp_iter_max, **{
                f"res_{r}_max": settings.qp_tol for r in "gbdm"}} | (
                    {} if settings.qp_mu0 is None else {"mu0": settings.qp_mu0})})
        # The QP through a wrapping function called on numpy buffers: H's and A's nonzeros go in as
        # they are (building DMs from them cost more than the QP's Riccati recursion). Calling the
        # conic itself through Function.buffer returns wrong steps from the second call on (CasADi
        # 3.8's HPIPM keeps stale state); through the wrapper the steps equal the DM calls' to the
        # bit (checked on 40 closed-loop QPs, in and out of order). The wrapper's call checks out the
        # conic's memory 1 (memory 0 serves direct calls): its statistics are read there.
        args = {"h": ca.MX.sym("h", h_sp), "a": ca.MX.sym("a", a_sp)}
        args |= {k: ca.MX.sym(k, qp.sparsity_in(k)) for k in ("g", "lba", "uba", "lbx", "ubx")}
        sol = qp(**args)
        self.qp = qp
        self._qp = NumpyCall(ca.Function(f"{name}_qp_call", list(args.values()),
                                         [sol["x"], sol["lam_a"], sol["lam_x"]], list(args), ["x", "lam_a", "lam_x"]))
        # where each nonzero of A and H comes from: A's from [T's dynamics blocks (N, nx, nxu), the
        # path constraints' blocks (N, ng, nxu), -1 (the -I blocks)], H's from the stages' blocks
        # (N, nxu, nxu) and a zero (the terminal block: the cost has no terminal term)
        src_a, src_h = np.full((na, nq), -1), np.full((nq, nq), N * nxu * nxu)
        n_dyn, n_path = N * nx * nxu, N * self.ng * nxu
        for k in range(N):
            r, col = k * (nx + self.ng), self._col[k]
            src_a[r:r + nx, col:col + nxu] = k * nx * nxu + np.arange(nx * nxu).reshape(nx, nxu)
            src_a[r + nx:r + nx + self.ng, col:col + nxu] = n_dyn + k * self.ng * nxu + np.arange(
                self.ng * nxu).reshape(self.ng, nxu)
            src_a[r:r + nx, self._col[k + 1]:self._col[k + 1] + nx][np.diag_indices(nx)] = n_dyn + n_path
            src_h[col:col + nxu, col:col + nxu] = k * nxu * nxu + np.arange(nxu * nxu).reshape(nxu, nxu)
        self._a_src, self._h_src = src_a[a_idx], src_h[h_idx]
        self._a_vals = np.zeros(n_dyn + n_path + 1)
        self._a_vals[-1] = -1.0
        self._h_vals = np.zeros(N * nxu * nxu + 1)
        nz = nx + nv
        self._keep = np.concatenate([np.r_[k * nz:k * nz + nxu] for k in range(N)] + [np.r_[N * nz:N * nz + nx]])

    # ------------------------------------------------------------------------------------------
    def _step_length(self, w: np.ndarray, step: np.ndarray, p: np.ndarray, lbg: np.ndarray, ubg: np.ndarray,
                     grad: np.ndarray, lam_a: np.ndarray, mu: float) -> tuple[float, float]:
        """The fraction of `step` that Armijo backtracking (halving) accepts on the L1 merit
        f + mu |c|_1, and the penalty mu used (never lowered across iterations). grad: the stage
        costs' gradients (N, ns) at w; lam_a: the QP's row multipliers."""
        N = self.pr.horizon
        ds = step[self._stage_idx].reshape(N, self.ns)
        slope, curvature = float(np.sum(grad * ds)), float(np.sum(self._h * ds * ds))
        over, cost = self._violations(w, p, lbg, ubg)
        c1 = float(over.sum())
        mu = max(mu, 1.5 * float(np.abs(lam_a).max(initial=0.0)))
        if c1 > 0.0:
            mu = max(mu, (slope + 0.5 * curvature) / (0.5 * c1))
        merit, decrease = cost + mu * c1, slope - mu * c1
        alpha = 1.0
        while alpha > SHORTEST:
            over, cost = self._violations(w + alpha * step, p, lbg, ubg)
            if cost + mu * float(over.sum()) <= merit + ARMIJO * alpha * decrease:
                break
            alpha /= 2
        return alpha, mu

    def _stages(self, w: np.ndarray) -> np.ndarray:
        """(ns, N) in column-major nonzero order: the stage vectors s_k one after the other."""
        return w[self._stage_idx]

    def _violations(self, w: np.ndarray, p: np.ndarray, lbg: np.ndarray, ubg: np.ndarray) -> tuple[np.ndarray, float]:
        """(every constraint's violation >= 0: the stage constraints, then x_0 = p[:nx]; cost) at w."""
        out = self._val(self._stages(w), p)
        c = out[0]
        over = np.maximum(np.maximum(lbg - c, c - ubg), 0.0)
        return np.concatenate([over, np.abs(w[:self.pr.nx] - p[:self.pr.nx])]), float(out[1][0])

    def evaluate(self, w: np.ndarray, p: np.ndarray, lbg: np.ndarray, ubg: np.ndarray) -> tuple[float, float]:
        """(largest violation of the stage constraints and of x_0 = p[:nx], cost) at w."""
        over, cost = self._violations(w, p, lbg, ubg)
        return float(over.max()), cost

    def eliminate(self, J: np.ndarray, c: np.ndarray, grad: np.ndarray) -> tuple[np.ndarray, ...]:
        """The QP on (dx_k, du_k) of each stage from its linearization: constraint Jacobians J (N, nc,
        ns) and values c (N, nc), cost gradients grad (N, ns). The columns of s are (x_k | u_k | z_k |
        x_k+1); the dynamics rows give [dx_k+1; dz_k] = T [dx; du; 1], so s = E [dx; du; 1] with E =
        [I 0; 0 I; T_z; T_x1]. Returns T (N, nd, nxu + 1), the Hessian E^T diag(h) E (N, nxu, nxu) and
        gradient E^T (grad + diag(h) e) (N, nxu) of the cost, and the path rows' Jacobian J E (N, ng,
        nxu) and values at [dx; du] = 0 (N, ng), written out on E's blocks (e: E's last column)."""
        nd, nxu, dep, h = self.nd, self.pr.nx + self.nu, self._dep, self._h
        rhs = np.concatenate([J[:, :nd, :nxu], c[:, :nd, None]], axis=2)
        T = -np.linalg.solve(J[:, :nd, dep], rhs)
        W, t = T[:, :, :-1], T[:, :, -1]
        WT = W.transpose(0, 2, 1)
        Hq = WT @ (h[:, dep, None] * W)
        Hq[:, np.arange(nxu), np.arange(nxu)] += h[:, :nxu]
        gq = grad[:, :nxu] + (WT @ (grad[:, dep] + h[:, dep] * t)[:, :, None])[:, :, 0]
        Jc_dep = J[:, nd:, dep]
        return T, Hq, gq, J[:, nd:, :nxu] + Jc_dep @ W, c[:, nd:] + (Jc_dep @ t[:, :, None])[:, :, 0]

    def solve(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray, lbg: np.ndarray,
              ubg: np.ndarray, settings: SQPSettings | None = None,
              stop: Callable[[np.ndarray], bool] | None = None) -> SQPResult:
        """From w0 with parameters p; lbw/ubw bound w, lbg/ubg bound the stage constraints (N nc,
        stage-major; the dynamics rows must be 0). `settings` replaces the iteration settings
        (max_iter, real_time, step_tol, violation_tol, line_search) for this solve; the QP's are
        fixed at construction. `stop(w)`, after each iteration: True ends the solve (STOPPED)."""
        t0 = time.perf_counter()
        pr, s = self.pr, settings or self.settings
        N, nx, nv, nd, ns, ng = pr.horizon, pr.nx, pr.nv, self.nd, self.ns, self.ng
        nz, nxu = nx + nv, nx + self.nu
        w = np.array(w0, float)
        lo_g = lbg.reshape(N, pr.nc)[:, nd:]
        hi_g = ubg.reshape(N, pr.nc)[:, nd:]
        if self._h is None:
            Hs = self._cost_hessian(self._stages(w), p)[0].reshape(N, ns, ns)
            h = np.diagonal(Hs, axis1=1, axis2=2).copy()
            if np.count_nonzero(Hs) != np.count_nonzero(h) or np.any(h[:, nxu:nz]):
                raise ValueError(f"{self.qp.name()}: the cost's Hessian must be diagonal and free of the algebraic "
                                 "variables; allowed: sum_i h_i s_i^2 / 2 + linear terms")
            self._h = h
        status, qp_iters, iterations, mu = SolverStatus.MAX_ITER, 0, 0, 0.0
        n_dyn = N * nx * nxu
        for iterations in range(1, s.max_iter + 1):  # noqa: B007 (the count is returned)
            out = self._lin(self._stages(w), p)
            c = out[0].reshape(N, pr.nc)
            J = out[1].reshape(N, ns, pr.nc).transpose(0, 2, 1)  # (N, nc, ns)
            grad = out[2].reshape(N, ns)
            T, Hq, gq, CD, ce = self.eliminate(J, c, grad)
            W, t = T[:, :, :-1], T[:, :, -1]
            # the QP in HPIPM's layout [dx_0, du_0, ..., dx_N]
            lba, uba = np.zeros((N, nx + ng)), np.zeros((N, nx + ng))
            lba[:, :nx] = uba[:, :nx] = -T[:, :nx, -1]
            lba[:, nx:], uba[:, nx:] = lo_g - ce, hi_g - ce
            self._a_vals[:n_dyn] = T[:, :nx, :-1].ravel()
            self._a_vals[n_dyn:-1] = CD.ravel()
            self._h_vals[:-1] = Hq.ravel()
            g = np.concatenate([gq.ravel(), np.zeros(nx)])
            lbx, ubx = (lbw - w)[self._keep], (ubw - w)[self._keep]
            lbx[:nx] = ubx[:nx] = p[:nx] - w[:nx]
            x, lam_a, _ = self._qp(self._h_vals[self._h_src], self._a_vals[self._a_src], g, lba.ravel(),
                                   uba.ravel(), lbx, ubx)
            st = self.qp.stats(1)  # (see __init__)
            qp_iters += int(st.get("iter_count", 0))
            if not st["success"]:
                status = SolverStatus.FAILED
                break
            d = x.copy()
            step = np.zeros_like(w)
            step[self._keep] = d
            dxu = d[:N * nxu].reshape(N, nxu)
            step[:N * nz].reshape(N, nz)[:, nxu:] = (W[:, nx:] @ dxu[:, :, None])[:, :, 0] + t[:, nx:]
            alpha = 1.0
            if s.line_search:
                alpha, mu = self._step_length(w, step, p, lbg, ubg, grad, lam_a, mu)
            w = w + alpha * step
            if np.abs(step).max() < s.step_tol:  # (the full step: a short one does not mean converged)
                status = SolverStatus.SUCCESS
                break
            if stop is not None and stop(w):
                status = SolverStatus.STOPPED
                break
        violation, cost = self.evaluate(w, p, lbg, ubg)
        if status is SolverStatus.STOPPED:
            return SQPResult(status, w, iterations, qp_iters, violation, cost, time.perf_counter() - t0)
        if status is SolverStatus.SUCCESS and violation > s.violation_tol:
            status = SolverStatus.MAX_ITER
        if status is SolverStatus.MAX_ITER and violation < FEASIBLE_VIOLATION:
            status = SolverStatus.FEASIBLE
        elif status is SolverStatus.MAX_ITER and s.real_time:
            status = SolverStatus.REAL_TIME
        return SQPResult(status, w, iterations, qp_iters, violation, cost, time.perf_counter() - t0)
