"""Compiled rollouts of the braking policy against the policy evaluated in numpy and stepped by the
model's RK4 one substep at a time (the arithmetic they compile)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import random_states

from controller.model import UVMSModel
from controller.rollouts import BrakingPolicy, JointHold


def reference(model: UVMSModel, policy: BrakingPolicy, h0: np.ndarray, posture: np.ndarray, dt: float, steps: int,
              substeps: int, current: np.ndarray, every_substep: bool) -> tuple[np.ndarray, np.ndarray]:
    hs, us = [h0], []
    for _ in range(steps):
        h, u_sum, u = hs[-1], 0.0, policy(hs[-1], posture, current)
        for _ in range(substeps):
            if every_substep:
                u = policy(h, posture, current)
            h = model.step(h, u, dt / substeps, vc=current)
            u_sum = u_sum + u
        hs.append(h)
        us.append(u_sum / substeps)
    return np.array(hs), np.array(us)


@pytest.mark.parametrize(("steps", "substeps", "dt", "every_substep", "hold"),
                         [(20, 4, 0.1, False, JointHold()), (10, 4, 0.04, True, JointHold(30.0, 3.0)),
                          (50, 1, 0.01, True, JointHold(30.0, 3.0))])
def test_compiled_rollout_is_the_policy_stepped_in_numpy(params, scene, steps, substeps, dt, every_substep,
                                                         hold) -> None:
    """Held per interval (the certificate's braking) and acting every substep (Mode II's deploy
    guess), from 6 random states in a random current, with every thruster live and with every one
    dead: states and inputs within 1e-6 relative (+1e-9 absolute). The operations are the same, but
    CasADi's symbolic 6x6 solve and LAPACK's round differently, and the stiff joint PD amplifies
    that over the rollout: 5e-8 relative after 20 intervals from these random states (up to 78
    rad/s), 1e-10 from a scenario's. A wrong term or gain shows at order one."""
    model = UVMSModel(params, scene.water)
    rng = np.random.default_rng(7)
    n, nt = params.n_joints, params.n_thrusters
    for dead in (False, True):
        policy = BrakingPolicy(model, hold)
        if dead:
            lo, hi = params.input_bounds()
            lo[:nt] = hi[:nt] = 0.0
            policy.limit_thrust(lo, hi)
        for h in random_states(params, 3, seed=11 + dead):
            current = rng.normal(0, 0.2, 3)
            posture = h[6:6 + n] + rng.normal(0, 0.3, n)
            hs, us = policy.rollout(h, posture, dt, steps, substeps, current, every_substep)
            ref_h, ref_u = reference(model, policy, h, posture, dt, steps, substeps, current, every_substep)
            np.testing.assert_allclose(hs, ref_h, rtol=1e-6, atol=1e-9)
            np.testing.assert_allclose(us, ref_u, rtol=1e-6, atol=1e-9)
            if dead:
                assert np.all(us[:, :nt] == 0.0)


def test_deploy_guess_is_the_policy_stepped_until_the_tip_touches(params, scene) -> None:
    """Mode II's deploy guess from a recorded Mode II entry (tests/data/wall_oblique_mode2_entry.npz)
    against its definition stepped in numpy: the deploy policy every 0.01 s until the tip's gap is
    <= 0 (time to contact t_c), N_p = Algorithm 1's horizon for t_c, dt = t_c / N_p, then N_p
    intervals with the policy every substep. Same t_c (also `time_to_contact`'s), N_p and dt, and
    states and inputs within 1e-9 (the same operations but for the 6x6 solve's rounding)."""
    import math
    from pathlib import Path

    from controller.mode2 import ModeIIOCP, ModeIISettings, next_horizon
    from controller.transcription import tip_gap

    model = UVMSModel(params, scene.water)
    rec = np.load(Path(__file__).parent / "data" / "wall_oblique_mode2_entry.npz")
    h0, current, wall = rec["h"], rec["current"], scene.planes[0]
    s = ModeIISettings()
    ocp = ModeIIOCP(model, scene.planes, 0, s)
    ocp.limit_inputs(rec["lo"], rec["hi"])
    hs, us, dt = ocp.deploy_guess(h0, s.horizon, current)
    posture, h, t_c = ocp.reach(h0), h0, None
    for i in range(math.ceil(s.horizon * s.dt_bounds[1] / 0.01)):
        h = model.step(h, ocp.deploy(h, posture, current), 0.01, vc=current)
        if float(tip_gap(model, h, wall)) <= 0.0:
            t_c = (i + 1) * 0.01
            break
    assert t_c is not None
    assert ocp.time_to_contact(h0, s.horizon, current) == pytest.approx(t_c, abs=1e-12)
    N = min(s.horizon, next_horizon(2, t_c, s.dt_nominal))
    assert len(us) == N and dt == pytest.approx(np.clip(t_c / N, *s.dt_bounds), abs=1e-12)
    ref_h, ref_u = reference(model, ocp.deploy, h0, posture, dt, N, math.ceil(dt / 0.01), current, True)
    np.testing.assert_allclose(hs, ref_h, rtol=0, atol=1e-9)
    np.testing.assert_allclose(us, ref_u, rtol=0, atol=1e-9)
