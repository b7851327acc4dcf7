"""The old feasibility tests' premise (that IPOPT fails on these problems) under perturbed starts,
on the code before the change (commit 1e40a67, which still has the sharp model and Stop.NONE):

    git worktree add /tmp/old 1e40a67
    cd /tmp/old && PYTHONPATH=/tmp/old python /path/to/experiments/portable_assertions/check_old.py

writes old.md beside this script.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(1, str(Path.cwd() / "tests"))

from test_feasibility import approach  # noqa: E402

from controller.feasibility import FeasibilityTest, Stop  # noqa: E402
from controller.mode1 import PITCH, ModeISettings  # noqa: E402
from controller.model import UVMSModel  # noqa: E402
from uvms import load_params, load_scene  # noqa: E402
from validation import mismatch, scenarios  # noqa: E402
from validation.closed_loop import SHARP, build_plant  # noqa: E402


def main() -> None:
    params, scene = load_params(), load_scene()
    cp, csc, _, _ = build_plant(scenarios.get("wall-oblique"), mismatch.DEFAULT, 1)
    ob = dict(np.load(Path.cwd() / "tests" / "data" / "wall_oblique_certificate_call.npz"))
    direction = np.random.default_rng(0).standard_normal(params.n_states)
    lines = ["| solver path | sharp model, 10 cm, 0.5 m/s (the old test: infeasible) | wall-oblique call, no pitch "
             "bound, run to its end (the old test: at its cap) |", "|---|---|---|"]
    for name, (opts, eps) in {"as recorded": ({}, 0.0), "h0 + 1e-9": ({}, 1e-9), "h0 - 1e-9": ({}, -1e-9),
                              "linear_solver spral": ({"linear_solver": "spral"}, 0.0)}.items():
        s = ModeISettings(pitch_limit=None, ipopt_options=opts)
        d = direction * eps
        sharp = FeasibilityTest(UVMSModel(params, scene.water, SHARP), scene.planes, s, stop=Stop.NONE,
                                plan_start=False)
        h, ref = approach(params, 0.1, 0.5)
        a = sharp(h + d, ref)
        test = FeasibilityTest(UVMSModel(cp, csc.water), csc.planes, s, stop=Stop.NONE)
        test.limit_inputs(ob["input_lo"], ob["input_hi"])
        b = test(ob["h0"] + d, ob["h_ref"], ob["current"])
        lines.append(f"| {name} | {a.verdict.value}, {a.solution.iterations} iterations | {b.verdict.value}, "
                     f"{b.solution.iterations} iterations, max pitch {np.abs(b.solution.h[:, PITCH]).max():.2f} rad |")
    (HERE / "old.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
