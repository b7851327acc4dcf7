"""The work around the solvers in a step, the pieces side by side: Mode III's projection onto the
wall (Newton's method against IPOPT on the same 4-variable problem, from states whose tip was put
on the wall and then moved by up to 1 cm and 0.05 rad, as Mode III's recomputed nodes are), the
braking rollout over Mode I's horizon (the certificate's first screen and Mode III's release
check: one compiled call against the policy stepped in numpy) and Mode II's deploy guess (asked by
the deploy deadline in every Mode I step near a wall, and at each Mode II entry: compiled rollouts
against the numpy loop that stops at contact). Each repetition runs the methods back to back on
the same state, so that the machine's drifts fall on them alike.

  python bench/step_overheads.py              # 200 states each (about 1 min)

States: around the recorded Mode II entry tests/data/wall_oblique_mode2_entry.npz (hull +-5 cm
and +-0.1 rad, joints +-0.2 rad, speeds +-0.1), with its current and input bounds. Writes
bench/results/step_overheads.md and its manifest: median and p95 [ms] per method, and the ratio
of the medians.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

from controller.mode2 import ModeIIOCP, ModeIISettings, next_horizon
from controller.mode3 import ModeIIIOCP, ModeIIISettings
from controller.model import UVMSModel
from controller.rollouts import BrakingPolicy
from controller.transcription import tip_gap
from uvms import load_params, load_scene

OUT = Path(__file__).parent / "results"
DATA = Path(__file__).parent.parent / "tests" / "data" / "wall_oblique_mode2_entry.npz"


def stepped(model: UVMSModel, policy: BrakingPolicy, h0: np.ndarray, posture: np.ndarray, dt: float, steps: int,
            substeps: int, current: np.ndarray, every_substep: bool) -> np.ndarray:
    """The rollout as numpy steps it: the policy, then `substeps` calls of the model's RK4 step."""
    h, hs = h0, [h0]
    for _ in range(steps):
        u = policy(h, posture, current)
        for _ in range(substeps):
            if every_substep:
                u = policy(h, posture, current)
            h = model.step(h, u, dt / substeps, vc=current)
        hs.append(h)
    return np.array(hs)


def deploy_stepped(ocp: ModeIIOCP, model: UVMSModel, h0: np.ndarray, N_max: int, current: np.ndarray) -> None:
    """Mode II's deploy guess as a numpy loop: 0.01 s steps until the tip touches, then N_p intervals."""
    s, wall = ocp.settings, ocp.planes[ocp.contact]
    posture, h, t_c = ocp.reach(h0), h0, None
    for i in range(math.ceil(N_max * s.dt_bounds[1] / 0.01)):
        h = model.step(h, ocp.deploy(h, posture, current), 0.01, vc=current)
        if float(tip_gap(model, h, wall)) <= 0.0:
            t_c = (i + 1) * 0.01
            break
    N = min(N_max, next_horizon(2, t_c, s.dt_nominal)) if t_c else N_max
    dt = float(np.clip(t_c / N if t_c else s.dt_bounds[1], *s.dt_bounds))
    stepped(model, ocp.deploy, h0, posture, dt, N, math.ceil(dt / 0.01), current, True)


def measure(count: int) -> dict[str, list[float]]:
    params, scene = load_params(), load_scene()
    model = UVMSModel(params, scene.water)
    rec = np.load(DATA)
    h_rec, current = rec["h"], rec["current"]
    m3, m2 = ModeIIIOCP(model, scene.planes, 0, ModeIIISettings()), ModeIIOCP(model, scene.planes, 0, ModeIISettings())
    for ocp in (m3, m2):
        ocp.limit_inputs(rec["lo"], rec["hi"])
    m2.prepare_guesses(m2.settings.horizon)
    braking = BrakingPolicy(model)
    braking.limit_thrust(rec["lo"], rec["hi"])
    braking.compiled_rollout(20, 4, False)
    n, rng = params.n_joints, np.random.default_rng(0)
    times: dict[str, list[float]] = {k: [] for k in (
        "projection: Newton", "projection: IPOPT", "braking rollout: compiled", "braking rollout: numpy steps",
        "deploy guess: compiled", "deploy guess: numpy steps")}

    def timed(name: str, f, *args) -> None:
        t0 = time.perf_counter()
        f(*args)
        times[name].append(time.perf_counter() - t0)

    for _ in tqdm(range(count), desc="states", unit="state"):
        h = h_rec.copy()
        h[:3] += rng.uniform(-0.05, 0.05, 3)
        h[3:6] += rng.uniform(-0.1, 0.1, 3)
        h[6:6 + n] += rng.uniform(-0.2, 0.2, n)
        h[6 + n:] += rng.uniform(-0.1, 0.1, len(h) - 6 - n)
        near = h.copy()  # as Mode III's recomputed nodes: the tip put on the wall, then drifted off it
        near[6:6 + n] = m3.onto_plane_ipopt(h)
        near[:3] += rng.uniform(-0.01, 0.01, 3)
        near[3:6] += rng.uniform(-0.02, 0.02, 3)
        near[6:6 + n] += rng.uniform(-0.05, 0.05, n)
        timed("projection: Newton", m3.onto_plane, near)
        timed("projection: IPOPT", m3.onto_plane_ipopt, near)
        posture = h[6:6 + n]
        timed("braking rollout: compiled", braking.rollout, h, posture, 0.1, 20, 4, current)
        timed("braking rollout: numpy steps", stepped, model, braking, h, posture, 0.1, 20, 4, current, False)
        timed("deploy guess: compiled", m2.deploy_guess, h, m2.settings.horizon, current)
        timed("deploy guess: numpy steps", deploy_stepped, m2, model, h, m2.settings.horizon, current)
    return times


def table(times: dict[str, list[float]], count: int) -> str:
    lines = ["# The work around the solvers, side by side", "",
             f"`python bench/step_overheads.py --states {count}` ({platform.machine()}, casadi {ca.__version__}): "
             f"{count} states around a recorded Mode II entry, the methods back to back on each. Times [ms].", "",
             "| piece | method | median | p95 | median / the first method's |", "|---|---|---|---|---|"]
    names = list(times)
    for first, second in zip(names[::2], names[1::2], strict=True):
        base = np.median(times[first])
        for name in (first, second):
            t = 1e3 * np.asarray(times[name])
            piece, method = name.split(": ")
            lines.append(f"| {piece} | {method} | {np.median(t):.2f} | {np.percentile(t, 95):.2f} | "
                         f"{np.median(times[name]) / base:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=200)
    a = ap.parse_args(argv)
    if a.states < 1:
        raise SystemExit(f"--states {a.states}; allowed: >= 1")
    text = table(measure(a.states), a.states)
    (OUT / "step_overheads.md").write_text(text)
    print(text)


if __name__ == "__main__":
    from validation import manifest

    with manifest.recorded(OUT / "step_overheads.manifest.json", {"data": str(DATA.name)}):
        main(sys.argv[1:])
