"""Mode I of the switching NMPC in closed loop on the paper's model itself (the MuJoCo closed loop
is tests/test_closed_loop.py): an approach the thrusters can stop."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from controller.mode1 import ModeIOCP, ModeISettings, Solver, SolverStatus
from controller.model import UVMSModel, water
from controller.sqp import QPMode, SQPSettings


def approach(params, speed: float = 0.3, target: float = 1.8) -> tuple[np.ndarray, np.ndarray]:
    """At rest at the origin but for `speed` [m/s] towards the wall 2 m ahead; target `target` m
    ahead with the arm at home."""
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[6:6 + n], h[6 + n] = params.arm.home, speed
    ref = np.zeros(params.n_states)
    ref[0], ref[6:6 + n] = target, params.arm.home
    return h, ref


@pytest.mark.slow
def test_compiled_stage_derivatives_give_the_expanded_solution(params, scene) -> None:
    """The NLP with per-stage derivatives compiled to C and assembled by block (controller.stage_nlp)
    and the same NLP expanded into one SX graph (CasADi's own derivatives) reach the same optimum:
    trajectories within 1e-6 and costs within 1e-8 relative (both solved to IPOPT tol 1e-9)."""
    model = UVMSModel(params, scene.water)
    h, ref = approach(params)
    sols = [ModeIOCP(model, scene.planes, ModeISettings(compiled=c, tol=1e-9, solver=Solver.IPOPT)).solve(h, ref)
            for c in (True, False)]
    assert all(s.status is SolverStatus.SUCCESS for s in sols)
    np.testing.assert_allclose(sols[0].h, sols[1].h, atol=1e-6)
    np.testing.assert_allclose(sols[0].u, sols[1].u, atol=1e-6 * np.abs(sols[1].u).max())
    assert sols[0].cost == pytest.approx(sols[1].cost, rel=1e-8)


def test_ipopt_stopped_by_its_wall_clock_limit_counts_as_its_iteration_cap(params, scene) -> None:
    """IPOPT's wall-clock limit (max_wall_time, which a preset can set through its ipopt_options)
    set to 1 ns stops it within its first iterations (here at its start). Oracle: the same solve
    capped at that many iterations without the limit; the two iterates are the same and so is the
    status (MAX_ITER, or FEASIBLE when the iterate satisfies the constraints), not a failure."""
    model = UVMSModel(params, scene.water)
    h, ref = approach(params)
    ipopt = ModeISettings(solver=Solver.IPOPT)
    limited = ModeIOCP(model, scene.planes, replace(ipopt, ipopt_options={"max_wall_time": 1e-9}))
    stopped = limited.solve(h, ref)
    assert limited.solver.stats()["return_status"] == "Maximum_WallTime_Exceeded"
    ocp = ModeIOCP(model, scene.planes, replace(ipopt, max_iter=stopped.iterations))
    capped = ocp.solve(h, ref)
    assert ocp.solver.stats()["return_status"] == "Maximum_Iterations_Exceeded"
    assert stopped.iterations < 5 and stopped.status in (SolverStatus.MAX_ITER, SolverStatus.FEASIBLE)
    assert stopped.status is capped.status
    np.testing.assert_array_equal(stopped.w, capped.w)


@pytest.mark.slow
def test_sqp_reaches_the_interior_point_optimum(params, scene) -> None:
    """The Gauss-Newton SQP with HPIPM's Riccati QP (controller.sqp: dynamics eliminated stage by
    stage, constraints' curvature left out) iterated to convergence from the same cold start
    reaches the optimum IPOPT finds with the exact Hessian (tol 1e-9): a fixed point of the SQP is
    a KKT point of the NLP. Tolerances: states within 1e-5 (m, rad, m/s), inputs within 1e-4 of
    their 40 N scale, cost within 1e-8 relative; the SQP stops at steps below 1e-7 and converges
    linearly (Gauss-Newton), so its iterate is this close, not closer. The QPs are HPIPM's ROBUST
    ones (residuals to 1e-6, the default, pinned here): the opt-in SPEED_ABS steps are accurate to
    about its barrier tolerance only, and with them the fixed point's cost is 1.6e-8 off."""
    model = UVMSModel(params, scene.water)
    h, ref = approach(params)
    ipopt = ModeIOCP(model, scene.planes, ModeISettings(tol=1e-9, solver=Solver.IPOPT)).solve(h, ref)
    sqp = ModeIOCP(model, scene.planes, ModeISettings(sqp=SQPSettings(
        max_iter=200, step_tol=1e-7, violation_tol=1e-9, real_time=False, qp_mode=QPMode.ROBUST))).solve(h, ref)
    assert ipopt.status is SolverStatus.SUCCESS and sqp.status is SolverStatus.SUCCESS
    assert sqp.violation < 1e-9
    np.testing.assert_allclose(sqp.h, ipopt.h, atol=1e-5)
    np.testing.assert_allclose(sqp.u, ipopt.u, atol=1e-4 * np.abs(ipopt.u).max())
    assert sqp.cost == pytest.approx(ipopt.cost, rel=1e-8)


@pytest.mark.slow
@pytest.mark.parametrize("solver", [Solver.SQP, Solver.IPOPT])
def test_avoidable_approach_stays_clear_and_settles(params, scene, solver: Solver) -> None:
    """Moving at 0.3 m/s towards the wall 2 m ahead, with a target 1.8 m ahead that the arm (at
    home it reaches 0.56 m in front of the hull) makes unreachable: Mode I brakes, folds the arm and
    stops at the 2 cm margin. Plant: the model itself, RK4 at 10 ms under a zero-order hold of the
    first input. Every solve succeeds; no body and not the end-effector tip ever comes closer than
    the margin minus 1 mm (the margin holds at the OCP's nodes; between nodes and under the
    RK4-vs-midpoint difference it may be undercut slightly); the hull comes to rest (speed below
    1 mm/s) within 8 s. Both solvers: the default real-time iteration (one SQP iteration per
    period, a usable REAL_TIME iterate or better) and IPOPT to convergence (SUCCESS)."""
    model = UVMSModel(params, scene.water)
    settings = ModeISettings(solver=solver)
    ocp = ModeIOCP(model, scene.planes, settings)
    n = params.n_joints
    h, ref = approach(params)
    previous, closest = None, np.inf
    for _ in range(80):
        sol = ocp.solve(h, ref, previous=previous)
        assert sol.status.usable if solver is Solver.SQP else sol.status is SolverStatus.SUCCESS
        previous = sol
        for _ in range(10):
            h = model.step(h, sol.u[0], settings.dt / 10)
            x_ee = np.asarray(model.ee_pose(h)[0]).ravel()
            for pl in scene.planes:
                closest = min(closest, float(np.asarray(model.distances(h, pl.normal, pl.offset)).min()),
                              pl.signed_distance(x_ee) - params.arm.tip_radius)
    assert closest > settings.distance_margin - 1e-3
    assert np.linalg.norm(h[6 + n:9 + n]) < 1e-3
    assert 1.5 < h[0] < 1.8  # as close as the folded arm allows, not at the unreachable target


@pytest.mark.slow
def test_avoidable_approach_in_mujoco_never_touches(params, scene) -> None:
    """The same approach with the MuJoCo plant (MuJoCo's fluid forces, added-mass iteration, joint
    friction: physics the controller does not know) in the loop, state measured every 0.1 s: every
    solve succeeds, no geom of the vehicle ever touches the wall (zero contact impulse), and
    MuJoCo's own distance stays above 1 cm (the 2 cm margin less what model mismatch may eat)."""
    from uvms_mj.plant import Plant

    model = UVMSModel(params, scene.water)
    ocp = ModeIOCP(model, scene.planes, ModeISettings())
    plant = Plant(params, scene)
    h, ref = approach(params)
    plant.reset(h)
    previous, closest = None, np.inf
    for _ in range(60):
        sol = ocp.solve(plant.state(), ref, previous=previous)
        assert sol.status.usable
        previous = sol
        report = plant.step(sol.u[0], 0.1)
        assert not report.contacts
        closest = min(closest, float(report.distances.min()))
    assert closest > 0.01
    assert abs(report.h[6 + params.n_joints]) < 0.01  # at rest


def test_sqp_reports_an_infeasible_qp_as_failed(params, scene) -> None:
    """A QP that cannot be solved is FAILED, never a usable plan, and does not spoil the next solve:
    after a solve from the avoidable approach, every clearance is asked to be 50 m (no input
    within the thrust limits moves the hull that far in 2 s), then the original problem is solved
    again. Oracle: the constraint bounds themselves (the iterate violates them by about 50 m)."""
    model = UVMSModel(params, scene.water)
    ocp = ModeIOCP(model, scene.planes, ModeISettings())
    h, ref = approach(params)
    first = ocp.solve(h, ref)
    sqp, pr = ocp.sqp, ocp.sqp.pr
    lbg, ubg = ocp.lbg[ocp.ns:].copy(), ocp.ubg[ocp.ns:].copy()
    lbg.reshape(pr.horizon, pr.nc)[:, sqp.nd:] = 50.0
    ubg.reshape(pr.horizon, pr.nc)[:, sqp.nd:] = np.inf
    bad = sqp.solve(first.w, np.concatenate([h, ref, water()]), ocp.lbw, ocp.ubw, lbg, ubg)
    again = ocp.solve(h, ref, previous=first)
    assert first.status.usable and again.status.usable
    assert bad.status is SolverStatus.FAILED and bad.violation > 40.0


def test_sqp_eliminates_the_implicit_dynamics_exactly(params, scene) -> None:
    """controller.sqp's QP on (dx_k, du_k), written out on E's blocks, against the dense products
    on the Mode I linearization at a solve's iterate: with E = [I 0; 0 I; T_z; T_x1] and e its last
    column, the dynamics rows' linearization vanishes along E (J_d E + [0 | c_d] = 0: the implicit
    function theorem), and the QP's Hessian, gradient, path-row Jacobian and values equal E^T H E,
    E^T (grad + H e), J_c E and c_c + J_c e with the cost's full Hessian H from CasADi. Tolerance:
    1e-9 relative per entry, and 1e-12 of the quantity's largest entry for entries near zero
    (rounding in 30 x 30 solves and 62-term sums)."""
    model = UVMSModel(params, scene.water)
    ocp = ModeIOCP(model, scene.planes, ModeISettings())
    h, ref = approach(params)
    sol = ocp.solve(h, ref)
    sqp, pr = ocp.sqp, ocp.sqp.pr
    N, nx, ns, nd, nxu = pr.horizon, pr.nx, sqp.ns, sqp.nd, pr.nx + sqp.nu
    p = np.concatenate([h, ref, water()])
    stages = sqp._stages(sol.w)
    c, J, grad = (o.copy() for o in sqp._lin(stages, p))
    c, J, grad = c.reshape(N, pr.nc), J.reshape(N, ns, pr.nc).transpose(0, 2, 1), grad.reshape(N, ns)
    H = sqp._cost_hessian(stages, p)[0].reshape(N, ns, ns)
    T, Hq, gq, CD, ce = sqp.eliminate(J, c, grad)
    E = np.zeros((N, ns, nxu + 1))
    E[:, :nxu, :nxu] = np.eye(nxu)
    E[:, nxu:nxu + sqp.n_alg] = T[:, nx:]
    E[:, nxu + sqp.n_alg:] = T[:, :nx]
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
