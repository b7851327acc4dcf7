"""Offline: Mode II's first solve from its deploy guess (cold) against a start from an answer solved
for a state 0.01-0.04 s earlier, without and with that answer's multipliers; four head-on
approaches, four states each (joint speeds perturbed by 0.02 rad/s, seed 0).

    python experiments/mode2_entry_helper/warm_probe.py > experiments/mode2_entry_helper/warm_probe.txt
"""

import time

import numpy as np

from controller.model import UVMSModel, water
from controller.switching import SwitchingNMPC
from uvms import load_params, load_scene
from validation.closed_loop import initial_state
from validation.scenarios import wall_approach


def timed(solve, *args) -> tuple[int, float, bool, float]:
    """solve(*args)'s IPOPT iterations, time [ms], usable, cost."""
    t0 = time.perf_counter()
    s = solve(*args)
    return s.iterations, 1e3 * (time.perf_counter() - t0), s.status.usable, s.cost


def main() -> None:
    params, scene = load_params(), load_scene()
    model = UVMSModel(params, scene.water)
    rng = np.random.default_rng(0)
    rows = []
    for gap, speed in [(0.4, 1.2), (0.35, 1.0), (0.5, 1.4), (0.3, 0.8)]:
        h, ref = initial_state(params, wall_approach(gap, speed))
        ctl = SwitchingNMPC(model, scene.planes, ref)
        wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")
        ocp, N, cur = ctl.ocp2(wall), ctl.settings.mode2.horizon, water(np.zeros(3))
        ans = ocp.solve(h, ocp.deploy_guess(h, N, cur), cur)
        for k in range(4):
            h2 = model.held_steps(h, ans.u[0], 0.01 * (k + 1), 4)  # the state a little later
            h2[6 + params.n_joints:] += rng.normal(0, 0.02, len(h2) - 6 - params.n_joints)
            start = (np.vstack([h2, ans.h[1:]]), ans.u, ans.dt)
            deploy = ocp.deploy_guess(h2, N, cur)  # (its ~10 ms not timed)
            out = {"deploy": timed(ocp.solve, h2, deploy, cur), "primal": timed(ocp.solve, h2, start, cur),
                   "duals": timed(ocp.solve, h2, start, cur, (ans.lam_g, ans.lam_x))}
            rows.append(out)
            print(gap, speed, k, {n: (v[0], round(v[1]), v[2], round(v[3], 4)) for n, v in out.items()})
    for n in ("deploy", "primal", "duals"):
        print(n, "median iterations", np.median([r[n][0] for r in rows]), "median ms",
              round(float(np.median([r[n][1] for r in rows])), 1), "usable", sum(r[n][2] for r in rows),
              "of", len(rows))


if __name__ == "__main__":
    main()
