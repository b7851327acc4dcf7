"""The plan's TV-LQR feedback (controller.plan_feedback) against independent checks: central
differences of the model's RK4, scipy's discrete Riccati solver, and the model's own RK4 closed
loop from a perturbed start."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from controller.model import UVMSModel, water
from controller.plan_feedback import FeedbackScales, PlanFeedback, references
from uvms import load_params, load_scene


@pytest.fixture(scope="module")
def setup() -> tuple[UVMSModel, PlanFeedback, np.ndarray, np.ndarray, np.ndarray]:
    model = UVMSModel(load_params(), load_scene().water)
    h = np.zeros(model.n_states)
    h[2], h[6:6 + model.n_joints], h[model.n_speeds] = -2.0, 0.3, 0.3
    u = np.zeros(model.n_inputs)
    u[:model.params.n_thrusters] = 2.0  # N each; the joints unactuated (the arm is about neutral in water)
    return model, PlanFeedback(model), h, u, water(np.array([0.2, 0.0, 0.0]))


def test_linearization_matches_central_differences(setup) -> None:
    """Forward differences at a relative step of 1e-6 against central ones at 1e-5 (error O(1e-10)):
    agree to 1e-4 of the largest entry, far below what moves an LQR gain."""
    model, fb, h, u, vc = setup
    A, B = fb.linearized(h, u, vc, 0.1)
    eps = 1e-5
    Ac = np.column_stack([(model.step(h + eps * e, u, 0.1, vc=vc) - model.step(h - eps * e, u, 0.1, vc=vc))
                          / (2 * eps) for e in np.eye(model.n_states)])
    Bc = np.column_stack([(model.step(h, u + eps * e, 0.1, vc=vc) - model.step(h, u - eps * e, 0.1, vc=vc))
                          / (2 * eps) for e in np.eye(model.n_inputs)])
    assert np.abs(A - Ac).max() < 1e-4 * np.abs(Ac).max()
    assert np.abs(B - Bc).max() < 1e-4 * np.abs(Bc).max()


def test_long_horizon_gain_is_the_discrete_riccati_one(setup) -> None:
    """Linearized once (every >= N) over 200 intervals, the first gain is the infinite-horizon LQR
    gain of scipy's solve_discrete_are to 1e-6 relative (the recursion converges geometrically)."""
    model, _, h, u, vc = setup
    fb = PlanFeedback(model, FeedbackScales(every=1000))
    N = 200
    K = fb.gains(np.tile(h, (N + 1, 1)), np.tile(u, (N, 1)), 0.1, vc)
    A, B = fb.linearized(h, u, vc, 0.1)
    P = scipy.linalg.solve_discrete_are(A, B, fb.Q, fb.R)
    K_are = -np.linalg.solve(fb.R + B.T @ P @ B, B.T @ P @ A)
    assert np.abs(K[0] - K_are).max() < 1e-6 * np.abs(K_are).max()


def test_feedback_brings_a_perturbed_start_back_to_the_plan(setup) -> None:
    """A 2 s plan of the model (its RK4 under constant thrust), started 5 cm, 0.05 rad and 0.1 rad
    off in hull position, yaw and a joint: under u_k + K_k (h - h_k), simulated by the model's RK4
    at 4 substeps an interval (finer than the gains' single step), the final state error in Q's
    norm is under a tenth of the open loop's."""
    model, fb, h, u, vc = setup
    N, dt = 20, 0.1
    us = np.tile(u, (N, 1))
    plan = [h]
    for k in range(N):
        plan.append(model.held_steps(plan[-1], us[k], dt, 4, vc=vc))
    plan = np.array(plan)
    K = fb.gains(plan, us, dt, vc)
    start = h.copy()
    start[0] += 0.05
    start[5] += 0.05
    start[6] += 0.1
    closed, open_ = start.copy(), start.copy()
    for k in range(N):
        closed = model.held_steps(closed, us[k] + K[k] @ (closed - plan[k]), dt, 4, vc=vc)
        open_ = model.held_steps(open_, us[k], dt, 4, vc=vc)

    def err(x: np.ndarray) -> float:
        return float((x - plan[-1]) @ fb.Q @ (x - plan[-1]))

    assert err(closed) < 0.1 * err(open_)


def test_references_lead_the_nodes_by_the_latency() -> None:
    """Row k's reference is the plan `lead` before node k, linear between nodes: with lead = dt/4,
    three quarters of the way from node k-1 to node k; with no lead node k itself."""
    h_pred = np.arange(4.0)[:, None] * np.ones((4, 2))
    np.testing.assert_allclose(references(h_pred, 3, 0.1, 0.025)[:, 0], [0.0, 0.75, 1.75])
    np.testing.assert_allclose(references(h_pred, 3, 0.1, 0.0)[:, 0], [0.0, 1.0, 2.0])
