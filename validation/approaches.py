"""Labelled wall approaches for the feasibility certificate's tests and benchmarks."""

from __future__ import annotations

import numpy as np

from controller.feasibility import FeasibilityTest
from validation.closed_loop import wall_x

# m/s: the speed above which F empties for the closest body 1 cm off the wall at 30 deg (a grid and
# bisection of the minimum-violation verdict with several starts, on the default model)
OBLIQUE_1CM_THRESHOLD = 0.783


def approach(test: FeasibilityTest, gap: float, angle: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """Level hull facing the wall, arm stowed, the closest body (the stowed arm's base, 47 mm ahead
    of the hull) `gap` m from the wall, moving at `speed` m/s `angle` deg off the wall's normal;
    the task 1 m back from the wall."""
    params = test.model.params
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[6:6 + n] = params.arm.stowed
    wall = next(pl for pl in test.problem.planes if pl.name == "wall")
    h[0] = float(np.min(np.asarray(test.model.distances(h, wall.normal, wall.offset)))) - gap  # (normal: -x)
    a = np.radians(angle)
    h[6 + n:8 + n] = speed * np.array([np.cos(a), np.sin(a)])
    ref = h.copy()
    ref[0], ref[6 + n:12 + n] = wall_x() - 1.0, 0.0
    return h, ref
