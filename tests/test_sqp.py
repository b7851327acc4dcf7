"""controller.sqp on Mode III's problem, which Mode I's does not exercise: a stage parameter, the
algebraic accelerations inside the stage's variables (u, a, F), a cost that is not a quadratic and
the Lagrangian's Hessian. Oracles: dense products from CasADi's own derivatives, and IPOPT's
solution and multipliers of the same NLP."""

from __future__ import annotations

import numpy as np
import pytest

from controller.model import water
from controller.sqp import Hessian, SQPSettings, StageSQP
from controller.transcription import SolverStatus


def _sqp(ocp, **settings) -> StageSQP:
    nu, nv = ocp.nu, ocp.nv
    return StageSQP(ocp.problem, ocp.name, algebraic=range(nu, nu + nv),
                    settings=SQPSettings(hessian=Hessian.LAGRANGIAN, real_time=False, **settings))


def _parameters(ocp, h: np.ndarray) -> np.ndarray:
    s = ocp.settings
    return np.concatenate([h, water(None), [s.hull_clearance, s.clearance_weight], ocp.weights])


@pytest.fixture(scope="module")
def tight(contact_case):
    """IPOPT's solution of the contact case from Algorithm 2's guess, to 1e-10."""
    model, ocp, h = contact_case
    tight_ocp = type(ocp)(model, ocp.planes, ocp.contact, type(ocp.settings)(
        tol=1e-10, ipopt_options={"acceptable_tol": 1e-10, "acceptable_constr_viol_tol": 1e-12}))
    tight_ocp.limit_inputs(ocp._lo_u, ocp._hi_u)
    guess = tight_ocp.contact_guess(h, np.zeros((tight_ocp.settings.horizon, model.n_inputs)), None)
    sol = tight_ocp.solve(h, guess)
    assert sol.status is SolverStatus.SUCCESS
    return tight_ocp, h, guess, sol


def test_the_qp_is_the_dense_product_with_the_accelerations_inside_the_stage(tight) -> None:
    """With the accelerations between the inputs and the contact force, the eliminated QP equals
    E^T H E, E^T (grad + H e), J_c E and c_c + J_c e, E's free rows the identity at (x_k, u_k, F_k)
    and its dependent rows T at (a_k, x_k+1), H the Lagrangian's Hessian from CasADi at IPOPT's
    multipliers, at Algorithm 2's guess (not a solution: the dynamics' residual e is not zero).
    Tolerance: 1e-9 relative, 1e-12 of the largest entry near zero (30 x 30 solves, 45-term sums)."""
    ocp, h, guess, sol = tight
    sqp = _sqp(ocp)
    N, nx, ns, nd, pr = sqp.pr.horizon, sqp.pr.nx, sqp.ns, sqp.nd, sqp.pr
    P = _parameters(ocp, h)
    stages, PK = sqp._stages(guess), sqp._stage_parameters(P)
    c, J, grad = (o.copy() for o in sqp._lin(stages, PK))
    c, J, grad = c.reshape(N, pr.nc), J.reshape(N, ns, pr.nc).transpose(0, 2, 1), grad.reshape(N, ns)
    H = sqp._lag_hessian(stages, PK, sol.lam_g[ocp.ns:])[0].reshape(N, ns, ns)
    T, Hq, gq, CD, ce = sqp.eliminate(J, c, grad, H)
    free, dep = sqp._free, sqp._dep
    assert np.array_equal(free[nx:], nx + np.r_[0:ocp.nu, ocp.nu + ocp.nv:ocp.nu + ocp.nv + 3])
    E = np.zeros((N, ns, len(free) + 1))
    E[:, free, np.arange(len(free))] = 1.0
    E[:, dep] = T
    Eb, e = E[:, :, :-1], E[:, :, -1]
    along = J[:, :nd] @ E
    along[:, :, -1] += c[:, :nd]

    def close(a: np.ndarray, b: np.ndarray) -> None:
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max())

    assert np.abs(along).max() < 1e-9 * np.abs(J[:, :nd]).max()
    close(Hq, Eb.transpose(0, 2, 1) @ H @ Eb)
    close(gq, (Eb.transpose(0, 2, 1) @ (grad + (H @ e[:, :, None])[:, :, 0])[:, :, None])[:, :, 0])
    close(CD, J[:, nd:] @ Eb)
    close(ce, c[:, nd:] + (J[:, nd:] @ e[:, :, None])[:, :, 0])


def test_the_multipliers_recovered_from_the_qp_are_ipopts_at_its_solution(tight) -> None:
    """One QP at IPOPT's solution (with IPOPT's multipliers in the Hessian): the path rows'
    multipliers are the QP's, the dynamics rows' are recovered backwards through the eliminated
    (a_k, x_k+1); all of them equal IPOPT's to 1e-4 of the largest (HPIPM stops at 1e-6 residuals,
    IPOPT at 1e-10), and the QP's step is below the SQP's step tolerance (the point is a KKT point)."""
    ocp, h, _, sol = tight
    sqp = _sqp(ocp, max_iter=1)
    lbw, ubw = ocp.bounds()
    r = sqp.solve(sol.w, _parameters(ocp, h), lbw, ubw, ocp.lbg[ocp.ns:], ocp.ubg[ocp.ns:],
                  lam=sol.lam_g[ocp.ns:])
    ipopt = sol.lam_g[ocp.ns:]
    assert np.abs(r.w - sol.w).max() < sqp.settings.step_tol
    assert np.abs(r.lam - ipopt).max() < 1e-4 * np.abs(ipopt).max()


def test_the_line_searched_sqp_reaches_ipopts_solution_from_algorithm_2s_guess(tight) -> None:
    """From Algorithm 2's guess (no multipliers: the first QP has the cost's Hessian only) the SQP
    with the merit line search converges (full step below 1e-3, constraints below 1e-6) within 30
    iterations, to IPOPT's solution: the cost within 1e-6 (IPOPT's tolerance, scaled), every
    variable within 2e-3 (m, rad, N; twice the step tolerance: its steps shrink by about half an
    iteration, the convexified Hessian's linear rate)."""
    ocp, h, guess, sol = tight
    lbw, ubw = ocp.bounds()
    r = _sqp(ocp, max_iter=30, line_search=True).solve(
        np.clip(guess, lbw, ubw), _parameters(ocp, h), lbw, ubw, ocp.lbg[ocp.ns:], ocp.ubg[ocp.ns:])
    assert r.status is SolverStatus.SUCCESS
    assert abs(r.cost - sol.cost) < 1e-6
    assert np.abs(r.w - sol.w).max() < 2e-3
