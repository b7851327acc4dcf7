"""The dm-control environment (validation.environment): the same physics as the testbed's Plant,
and a reward that is zero while the hull touches."""

from __future__ import annotations

import numpy as np

from uvms_mj.plant import Plant
from validation.environment import load
from validation.scenarios import get


def test_environment_steps_exactly_like_the_plant(params) -> None:
    """Oracle: the testbed's Plant built from the same parameters, reset to the same start and
    stepped with the same inputs over the same 0.1 s periods gives bit-identical states (the
    environment delegates its physics to Plant.step). The action spec is the file's input bounds."""
    env = load("avoid-wall", mismatch="")
    spec = env.action_spec()
    lo, hi = params.input_bounds()
    np.testing.assert_array_equal(spec.minimum, lo)
    np.testing.assert_array_equal(spec.maximum, hi)
    ts = env.reset()
    plant = Plant(params, env.physics.plant.scene)
    plant.reset(ts.observation["state"])
    rng = np.random.default_rng(0)
    for _ in range(5):
        u = rng.uniform(lo, hi)
        ts = env.step(u)
        report = plant.step(u, 0.1)
        np.testing.assert_array_equal(ts.observation["state"], report.h)


def test_reward_is_zero_while_the_hull_touches(params) -> None:
    """Thrusters dead, reversing at 0.5 m/s into the wall 2 cm behind the hull (turned 180 deg, so
    that the stowed arm, which sits ahead of the hull's front, is away from the wall), no action:
    within 0.3 s the hull touches (MuJoCo reports a hull contact) and that step's reward is 0;
    before it the reward is positive."""
    sc = get("thrusters-dead").with_overrides({"current.velocity": "0,0,0", "duration": "1"})
    env = load(sc, mismatch="")
    n = params.n_joints
    h0 = env.task.h0
    h0[0], h0[5], h0[6 + n] = 2.0 - params.hull.superellipsoid.semi_axes[0] - 0.02, np.pi, -0.5
    env.reset()
    rewards, touched = [], []
    for _ in range(3):
        ts = env.step(np.zeros(env.action_spec().shape))
        rewards.append(ts.reward)
        touched.append(any(c.body == "hull" for c in env.physics.last_report.contacts))
    assert any(touched)
    assert all(r == 0.0 for r, t in zip(rewards, touched, strict=True) if t)
    assert all(r > 0.0 for r, t in zip(rewards, touched, strict=True) if not t)
