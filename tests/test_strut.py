"""The strut (controller.strut): a rest of the model with the tip on the wall, checked against the
model's own forward dynamics, and Mode III's terminal cost checked to pull towards it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from controller.mode3 import ModeIIIOCP, ModeIIISettings
from controller.model import UVMSModel, water
from controller.rollouts import ReachPosture
from controller.strut import StrutProblem
from controller.transcription import clearances, obstacle_frame, tip_gap
from validation.closed_loop import initial_state
from validation.scenarios import wall_approach

CURRENT = np.array([0.25, 0.0, 0.0])  # m/s onto the wall: thrusters-dead's current
FRICTION, MARGIN = 0.5, 0.005


@pytest.fixture(scope="module")
def dead_on_wall(params, scene):
    """Thrusters dead (bounds 0), hull 0.35 m from the wall, tip on the wall."""
    model = UVMSModel(params, scene.water)
    lo, hi = params.input_bounds()
    lo[:8] = hi[:8] = 0.0
    h, _ = initial_state(params, wall_approach(0.35, 0.3))
    n = params.n_joints
    h[6:6 + n] = ReachPosture(model, scene.planes[0])(h)
    ocp = ModeIIIOCP(model, scene.planes, 0, ModeIIISettings())
    ocp.limit_inputs(lo, hi)
    h[6:6 + n] = ocp.onto_plane(h)
    h[6 + n:] = 0.0
    return model, h, lo, hi


def test_the_strut_is_a_rest_of_the_model(dead_on_wall, scene) -> None:
    """The model's forward dynamics (M^-1 Q, not the strut's Q = 0 rows) at the strut with its
    inputs and contact force held: every acceleration below 1e-6 (m/s^2, rad/s^2; IPOPT's 1e-8 N
    on Q over masses and inertias of 1e-2 and up); the tip on the wall (1e-8 m), the force inside
    the friction pyramid and the jaws' limit, every other body at least the margin off (1e-8);
    the thrusters at 0 (their bounds); and the hull farther off than at the start."""
    model, h, lo, hi = dead_on_wall
    problem = StrutProblem(model, scene.planes, 0, FRICTION, MARGIN)
    problem.limit_inputs(lo, hi)
    strut = problem.solve(h, CURRENT)
    assert strut is not None
    nv = model.n_speeds
    np.testing.assert_array_equal(strut.h[nv:], 0.0)
    Fw = np.concatenate([strut.force, np.zeros(3)])
    hdot = model.hdot(strut.h, strut.u, Fw=Fw, Rw=obstacle_frame(scene.planes[0].normal), vc=water(CURRENT))
    assert np.max(np.abs(hdot[nv:])) < 1e-6
    assert abs(float(tip_gap(model, strut.h, scene.planes[0]))) < 1e-8
    assert 0.0 < strut.force[0] <= model.params.arm.tip_force_limit
    assert np.all(np.abs(strut.force[1:]) <= FRICTION * strut.force[0] + 1e-8)
    assert np.min(np.asarray(clearances(model, strut.h, scene.planes, 0))) > MARGIN - 1e-8
    np.testing.assert_array_equal(strut.u[:8], 0.0)
    start = float(np.asarray(model.distances(h, scene.planes[0].normal, scene.planes[0].offset)).ravel()[0])
    assert strut.distance > start


def test_mode3_terminal_cost_pulls_towards_the_strut(dead_on_wall, scene) -> None:
    """Mode III from the same state, with and without `strut_weight`: the plan's last joint angles
    end nearer the strut's with it (the cost's sign and indices), and the plan keeps the tip on
    the wall either way."""
    model, h, lo, hi = dead_on_wall
    n, ends = model.n_joints, {}
    for weight in (0.0, 1.0):
        ocp = ModeIIIOCP(model, scene.planes, 0, dataclasses.replace(ModeIIISettings(), strut_weight=weight))
        ocp.limit_inputs(lo, hi)
        guess = ocp.contact_guess(h, np.zeros((ocp.settings.horizon, model.n_inputs)), None, CURRENT)
        sol = ocp.solve(h, guess, CURRENT)
        assert sol.status.usable
        assert abs(float(tip_gap(model, sol.h[-1], scene.planes[0]))) < 1e-6
        ends[weight] = sol.h[-1][6:6 + n]
        if weight > 0.0:
            assert ocp.strut is not None
            target = ocp.strut.h[6:6 + n]
    assert np.linalg.norm(ends[1.0] - target) < np.linalg.norm(ends[0.0] - target)
