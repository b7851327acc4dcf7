"""Mode I of the switching NMPC in closed loop on the paper's model itself (the MuJoCo closed loop
is a separate issue): an approach the thrusters can stop."""

from __future__ import annotations

import numpy as np
import pytest

from controller.mode1 import ModeIOCP, ModeISettings, SolverStatus
from controller.model import UVMSModel


@pytest.mark.slow
def test_avoidable_approach_stays_clear_and_settles(params, scene) -> None:
    """Moving at 0.3 m/s towards the wall 2 m ahead, with a target 1.8 m ahead that the arm (at
    home it reaches 0.56 m in front of the hull) makes unreachable: Mode I brakes, folds the arm and
    stops at the 2 cm margin. Plant: the model itself, RK4 at 10 ms under a zero-order hold of the
    first input. Every solve succeeds; no body and not the end-effector tip ever comes closer than
    the margin minus 1 mm (the margin holds at the OCP's nodes; between nodes and under the
    RK4-vs-midpoint difference it may be undercut slightly); the hull comes to rest (speed below
    1 mm/s) within 8 s."""
    model = UVMSModel(params, scene.water)
    settings = ModeISettings()
    ocp = ModeIOCP(model, scene.planes, settings)
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[6:6 + n], h[6 + n] = params.arm.home, 0.3
    ref = np.zeros(params.n_states)
    ref[0], ref[6:6 + n] = 1.8, params.arm.home
    previous, closest = None, np.inf
    for _ in range(80):
        sol = ocp.solve(h, ref, previous=previous)
        assert sol.status is SolverStatus.SUCCESS
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
