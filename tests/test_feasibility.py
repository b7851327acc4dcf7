"""Mode I's feasibility certificate on head-on approaches to the wall with the arm stowed."""

from __future__ import annotations

import numpy as np
import pytest

from controller.feasibility import FeasibilityTest, Method, Verdict
from controller.model import UVMSModel

WALL_X = 2.0  # m, the default scene's wall


@pytest.fixture(scope="module")
def certificate(params, scene) -> FeasibilityTest:
    return FeasibilityTest(UVMSModel(params, scene.water), scene.planes)


def approach(params, gap: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """Hull front `gap` [m] from the wall (hull superellipsoid semi-axis a ahead of its origin),
    moving at `speed` [m/s] towards it, arm stowed; the task target 1 m from the wall."""
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[0] = WALL_X - params.hull.superellipsoid.semi_axes[0] - gap
    h[6:6 + n], h[6 + n] = params.arm.stowed, speed
    ref = h.copy()
    ref[0], ref[6 + n] = WALL_X - 1.0, 0.0
    return h, ref


@pytest.mark.slow
@pytest.mark.parametrize(("gap", "speed", "verdict", "method"), [
    (1.5, 0.3, Verdict.FEASIBLE, Method.BRAKING_ROLLOUT),
    (0.2, 0.5, Verdict.FEASIBLE, Method.BRAKING_ROLLOUT),
    (0.07, 0.3, Verdict.FEASIBLE, Method.MINIMUM_VIOLATION),
    (0.05, 0.8, Verdict.INFEASIBLE, Method.MINIMUM_VIOLATION),
], ids=["far", "braking suffices", "tight: the rollout fails, the OCP does not", "unavoidable"])
def test_certificate(certificate, params, gap, speed, verdict, method) -> None:
    """The braking rollout certifies easy cases by exhibiting a feasible point; a tight case it
    cannot certify is certified by a zero minimum violation (below the 1 mm tolerance); the
    unavoidable case (0.8 m/s, 5 cm: maximum braking needs about 7 cm) leaves a clearly positive
    minimum violation (more than 10 times the tolerance; IPOPT's local optima here were 2.5 and
    12.8 cm from two starting points: the problem is not convex)."""
    h, ref = approach(params, gap, speed)
    c = certificate(h, ref)
    assert (c.verdict, c.method) == (verdict, method)
    if method is Method.MINIMUM_VIOLATION:
        assert c.rollout_clearance < 0
        if verdict is Verdict.FEASIBLE:
            assert c.violation <= certificate.tolerance
        else:
            assert c.violation > 10 * certificate.tolerance


@pytest.mark.slow
def test_plan_screen_accepts_only_plans_inside_the_bounds(certificate, params) -> None:
    """The plan screens (previous plan, fresh Mode I plan) certify F by exhibiting a point of it.
    Oracle: the braking rollout of the 'far' case, which keeps every clearance above the margin
    (the certificate's own first screen says so), is accepted; the same states with one thruster
    input 1 N beyond its bound, or with the hull's front at the last node 1 cm from the wall (inside
    the 2 cm margin), are not."""
    h, ref = approach(params, 1.5, 0.3)
    assert certificate(h, ref).method is Method.BRAKING_ROLLOUT
    hs, us = certificate.braking_rollout(h)
    assert certificate.plan_is_feasible(hs, us)
    hi = params.input_bounds()[1]
    over = us.copy()
    over[3, 0] = hi[0] + 1.0
    assert not certificate.plan_is_feasible(hs, over)
    close = hs.copy()
    close[-1, 0] += WALL_X - 0.01 - (hs[-1, 0] + params.hull.superellipsoid.semi_axes[0])  # hull front 1 cm off
    assert not certificate.plan_is_feasible(close, us)
