"""Prototype: the certificate's minimum-violation problem by an elastic SQP on HPIPM, against the
default certificate (IPOPT to its witness or convergence).

The SQP is controller.sqp's StageSQP, one QP per iteration, full steps; the clearance slacks are QP
controls with an L1 cost (plus 1e-4 sigma^2 so that the QP's Hessian is positive on them) and the
stage layout (h, u, sigma, a, h+) puts them before the algebraic accelerations, as StageSQP asks.
Each iteration's inputs are re-simulated by RK4 from the measured state: a plan that keeps the
margin is a witness (F not empty), as in controller.feasibility. Cases: head-on approaches with
every thruster working, and the three certificate calls recorded in tests/data.

  python experiments/min_violation_sqp/prototype.py   # from the repository root; writes manifest.json
"""

from __future__ import annotations

import time
from pathlib import Path

import casadi as ca
import numpy as np

from controller.feasibility import FeasibilityTest
from controller.mode1 import PITCH, ModeISettings, _default_state_weights
from controller.model import UVMSModel
from controller.sqp import SQPSettings, StageSQP
from controller.stage_nlp import StageProblem
from controller.transcription import SolverStatus, clearances, midpoint_residual
from uvms import load_params, load_scene
from validation import manifest

WALL_X = 2.0  # m, the default scene's wall
DATA = Path(__file__).parents[2] / "tests" / "data"
CALLS = ("wall_headon_certificate_call.npz", "wall_oblique_certificate_call.npz", "wall_oblique_fresh_plan_call.npz")
APPROACHES = ((0.1, 0.5), (0.05, 0.3), (0.05, 1.0), (0.1, 1.5), (0.02, 0.8), (0.1, 2.0))  # (gap m, speed m/s)
ITERATIONS = 10


class ElasticMinViolation:
    """The minimum-violation problem of Mode I (default settings) on StageSQP."""

    def __init__(self, model: UVMSModel, scene) -> None:
        s, p = ModeISettings(), model.params
        self.model, self.s = model, s
        ns, nu, nv, n = model.n_states, model.n_inputs, model.n_speeds, model.n_joints
        h = ca.SX.sym("h", ns)
        self.clear = ca.Function("clear", [h], [clearances(model, h, scene.planes)])
        nc = self.clear.size1_out(0)
        nz = ns + nu + nc + nv
        self.ns, self.nu, self.nv, self.nc, self.nz, N = ns, nu, nv, nc, nz, s.horizon
        st, P = ca.SX.sym("s", nz + ns), ca.SX.sym("P", 2 * ns + 3)
        hk, uk, sk, ak, hk1 = st[:ns], st[ns:ns + nu], st[ns + nu:ns + nu + nc], st[ns + nu + nc:nz], st[nz:]
        e = hk1 - P[ns:2 * ns]
        tracking = ca.dot(ca.DM(_default_state_weights(n)) * e, e) + s.input_weight * ca.dot(uk, uk)
        cost = ca.sum1(sk) + 1e-4 * ca.dot(sk, sk) + 1e-6 * tracking
        cons = ca.vertcat(midpoint_residual(model, hk, uk, ak, hk1, s.dt, P[2 * ns:]), self.clear(hk1) + sk)
        problem = StageProblem(nx=ns, nv=nz - ns, horizon=N, np=2 * ns + 3, cost=ca.Function("c", [st, P], [cost]),
                               constraints=ca.Function("g", [st, P], [cons]))
        self.sqp = StageSQP(problem, "proto_minviol", n_alg=nv, settings=SQPSettings(qp_mu0=0.1))
        self.lbw, self.ubw = np.full(N * nz + ns, -np.inf), np.full(N * nz + ns, np.inf)
        q_lo = np.array([lk.joint_range[0] for lk in p.arm.links])
        q_hi = np.array([lk.joint_range[1] for lk in p.arm.links])
        for k in range(1, N + 1):
            i = k * nz
            self.lbw[i + 6:i + 6 + n], self.ubw[i + 6:i + 6 + n] = q_lo, q_hi
            self.lbw[i + PITCH], self.ubw[i + PITCH] = -s.pitch_limit, s.pitch_limit
        for k in range(N):
            self.lbw[k * nz + ns + nu:k * nz + ns + nu + nc] = 0.0
        self.lbg = np.tile(np.r_[np.zeros(ns + nv), np.full(nc, s.distance_margin)], N)
        self.ubg = np.tile(np.r_[np.zeros(ns + nv), np.full(nc, np.inf)], N)

    def guess(self, hs: np.ndarray, us: np.ndarray) -> np.ndarray:
        ns, nv, dt = self.ns, self.nv, self.s.dt
        blocks = [np.concatenate([hs[k], us[k], np.maximum(0.0, self.s.distance_margin - np.asarray(
            self.clear(hs[k + 1])).ravel()), (hs[k + 1, ns - nv:] - hs[k, ns - nv:]) / dt]) for k in range(len(us))]
        return np.concatenate([*blocks, hs[-1]])

    def __call__(self, test: FeasibilityTest, h0, ref, current, lo, hi) -> tuple[str, int, float]:
        """(verdict text, iterations, seconds) from the braking rollout, at most ITERATIONS iterations."""
        ns, nu, nc, nz, N = self.ns, self.nu, self.nc, self.nz, self.s.horizon
        for k in range(N):
            self.lbw[k * nz + ns:k * nz + ns + nu], self.ubw[k * nz + ns:k * nz + ns + nu] = lo, hi
        t0 = time.perf_counter()
        w, p = self.guess(*test.braking_rollout(h0, current)), np.concatenate([h0, ref, current])
        one = SQPSettings(max_iter=1, real_time=False, qp_mu0=0.1)
        for k in range(1, ITERATIONS + 1):
            r = self.sqp.solve(w, p, self.lbw, self.ubw, self.lbg, self.ubg, one)
            w = r.w
            us = np.array([w[j * nz + ns:j * nz + ns + nu] for j in range(N)])
            if test.resimulated_if_feasible(h0, us, current) is not None:
                return "feasible (witness)", k, time.perf_counter() - t0
            if r.status is SolverStatus.SUCCESS or r.status is SolverStatus.FAILED:
                break
        slack = sum(w[j * nz + ns + nu:j * nz + ns + nu + nc].sum() for j in range(N))
        return f"slack sum {slack:.4f} m ({r.status.value})", k, time.perf_counter() - t0


def main() -> None:
    params, scene = load_params(), load_scene()
    model = UVMSModel(params, scene.water)
    test, elastic = FeasibilityTest(model, scene.planes), ElasticMinViolation(model, scene)
    lo, hi = params.input_bounds()
    n = params.n_joints
    cases = []
    for gap, speed in APPROACHES:
        h = np.zeros(params.n_states)
        h[0] = WALL_X - params.hull.superellipsoid.semi_axes[0] - gap
        h[6:6 + n], h[6 + n] = params.arm.stowed, speed
        ref = h.copy()
        ref[0], ref[6 + n] = WALL_X - 1.0, 0.0
        cases.append((f"head-on, {gap} m at {speed} m/s", h, ref, np.zeros(3), lo, hi))
    for name in CALLS:
        rec = dict(np.load(DATA / name))
        cases.append((name, rec["h0"], rec["h_ref"], rec["current"], rec["input_lo"], rec["input_hi"]))
    t_all = time.perf_counter()
    for name, h0, ref, current, lo_u, hi_u in cases:
        test.limit_inputs(lo_u, hi_u)
        t0 = time.perf_counter()
        c = test(h0, ref, current)
        seconds = time.perf_counter() - t0
        verdict, k, t_e = elastic(test, h0, ref, current, lo_u, hi_u)
        print(f"{name}: IPOPT {c.verdict.value} ({c.method.value}, violation {c.violation:.4f} m, "
              f"{1e3 * seconds:.0f} ms) | elastic SQP {verdict} after {k} iterations, {1e3 * t_e:.0f} ms")
    manifest.write(Path(__file__).parent, {"prototype": "elastic SQP on the minimum-violation problem",
                                           "iterations": ITERATIONS}, time.perf_counter() - t_all,
                   ["python", "experiments/min_violation_sqp/prototype.py"])


if __name__ == "__main__":
    main()
