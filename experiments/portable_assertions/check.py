"""The feasibility tests' oracle under perturbed starts and another linear solver.

    python experiments/portable_assertions/check.py    # writes new.md and new.manifest.json here

Each of four recorded certificate calls is certified under five solver paths (as recorded, h0 +-
1e-9 in a random direction, IPOPT's linear_solver spral, and both); the tests' own oracle
(tests/test_feasibility.py: assert_certified, and the pitch bound on the wall-oblique call) must
pass on every one.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "tests"))

from test_feasibility import PITCH, approach, assert_certified, recorded  # noqa: E402

from controller.feasibility import FeasibilityTest  # noqa: E402
from controller.mode1 import ModeISettings  # noqa: E402
from controller.model import UVMSModel  # noqa: E402
from controller.rollouts import simulate  # noqa: E402
from uvms import load_params, load_scene  # noqa: E402
from validation import manifest, mismatch, scenarios  # noqa: E402
from validation.closed_loop import build_plant  # noqa: E402

VARIANTS = {"as recorded": ({}, 0.0), "h0 + 1e-9": ({}, 1e-9), "h0 - 1e-9": ({}, -1e-9),
            "linear_solver spral": ({"linear_solver": "spral"}, 0.0),
            "spral, h0 + 1e-9": ({"linear_solver": "spral"}, 1e-9)}


def main() -> None:
    params, scene = load_params(), load_scene()
    cp, csc, _, _ = build_plant(scenarios.get("wall-oblique"), mismatch.DEFAULT, 1)
    direction = np.random.default_rng(0).standard_normal(params.n_states)
    lines = ["| solver path | call | oracle | status | iterations |", "|---|---|---|---|---|"]
    for name, (opts, eps) in VARIANTS.items():
        s = ModeISettings(ipopt_options=opts)
        default = FeasibilityTest(UVMSModel(params, scene.water), scene.planes, s)
        oblique = FeasibilityTest(UVMSModel(cp, csc.water), csc.planes, s)
        d = direction * eps
        h, ref = approach(params, 0.1, 0.5)
        headon, ob, fp = (recorded(f) for f in ("wall_headon_certificate_call.npz",
                                                 "wall_oblique_certificate_call.npz",
                                                 "wall_oblique_fresh_plan_call.npz"))
        cases = [("head-on, 10 cm, 0.5 m/s", default, h + d, ref, None, None),
                 ("wall-headon call", default, headon["h0"] + d, headon["h_ref"], headon, True),
                 ("wall-oblique call (pitch bound)", oblique, ob["h0"] + d, ob["h_ref"], ob, False),
                 ("wall-oblique fresh-plan call", oblique, fp["h0"] + d, fp["h_ref"], fp, True)]
        for label, test, h0, h_ref, rec, fresh in cases:
            current = rec["current"] if rec is not None else None
            if rec is not None:
                test.limit_inputs(rec["input_lo"], rec["input_hi"])
            plan = (rec["fresh_h"], rec["fresh_u"]) if fresh else None
            c = test(h0, h_ref, current, fresh=(lambda p=plan: p) if plan else None)
            try:
                assert_certified(test, h0, c, current)
                hs = simulate(test.model, h0, c.solution.u, test.settings.dt, substeps=20, current=current)
                verdict = "pass" + (f", max pitch {np.abs(hs[:, PITCH]).max():.2f} rad" if "pitch" in label else "")
            except AssertionError:
                verdict = f"FAIL ({c.verdict.value})"
            test.limit_inputs(*test.model.params.input_bounds())
            sol = c.solution
            lines.append(f"| {name} | {label} | {verdict} | {sol.status.value if sol else '-'} | "
                         f"{sol.iterations if sol else '-'} |")
    (HERE / "new.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    with manifest.recorded(HERE / "new.manifest.json"):
        main()
