"""Accuracy of Mode I's feasibility certificate (issue 4) on labelled wall approaches.

Ground truth: the model's maximum-braking rollout (controller.feasibility.FeasibilityTest.
braking_rollout). For each approach (hull front `gap` m from the wall, heading at `angle` deg to
its normal, arm stowed) the threshold speed v* above which braking cannot keep the 2 cm margin is
found by bisection; speeds at 0.5, 0.8, 0.9, 1.1, 1.25 and 1.5 v* (outside the +-5% band) are then
labelled avoidable (< v*) or unavoidable (> v*) and given to the certificate.

`python -m validation.certificate_accuracy` prints the table and writes
bench/results/certificate_accuracy.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from controller.feasibility import FeasibilityTest, Verdict
from controller.model import UVMSModel
from uvms import load_params, load_scene
from validation.closed_loop import wall_x

FACTORS = (0.5, 0.8, 0.9, 1.1, 1.25, 1.5)
OUT = Path(__file__).resolve().parent.parent / "bench" / "results"


@dataclass(frozen=True)
class Case:
    gap: float  # m
    angle: float  # deg between the velocity and the wall's inward normal
    speed: float  # m/s
    threshold: float  # m/s
    truth: Verdict
    verdict: Verdict
    violation: float
    seconds: float


def approach(params, gap: float, angle: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[0] = wall_x() - params.hull.superellipsoid.semi_axes[0] - gap
    h[6:6 + n] = params.arm.stowed
    a = np.radians(angle)
    h[6 + n:8 + n] = speed * np.array([np.cos(a), np.sin(a)])
    ref = h.copy()
    ref[0], ref[6 + n:12 + n] = wall_x() - 1.0, 0.0
    return h, ref


def rollout_feasible(test: FeasibilityTest, h: np.ndarray) -> bool:
    hs, _ = test.braking_rollout(h)
    return min(float(np.asarray(test.problem._clearance(x)).min()) for x in hs[1:]) >= test.settings.distance_margin


def threshold_speed(test: FeasibilityTest, params, gap: float, angle: float) -> float:
    lo, hi = 0.0, 3.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if rollout_feasible(test, approach(params, gap, angle, mid)[0]) else (lo, mid)
    return 0.5 * (lo + hi)


def evaluate(approaches=((0.1, 0.0), (0.3, 0.0), (0.1, 30.0), (0.3, 30.0))) -> list[Case]:
    params, scene = load_params(), load_scene()
    test = FeasibilityTest(UVMSModel(params, scene.water), scene.planes)
    cases = []
    for gap, angle in approaches:
        v_star = threshold_speed(test, params, gap, angle)
        for f in FACTORS:
            h, ref = approach(params, gap, angle, f * v_star)
            c = test(h, ref)
            truth = Verdict.FEASIBLE if f < 1 else Verdict.INFEASIBLE
            cases.append(Case(gap, angle, f * v_star, v_star, truth, c.verdict, c.violation, c.solve_time))
    return cases


def main() -> None:
    cases = evaluate()
    lines = ["| gap [m] | angle [deg] | v* [m/s] | speed / v* | truth (braking rollout) | certificate | "
             "min. violation [m] | time [s] |", "|---|---|---|---|---|---|---|---|"]
    for c in cases:
        lines.append(f"| {c.gap:g} | {c.angle:g} | {c.threshold:.3f} | {c.speed / c.threshold:.2f} | {c.truth.value} | "
                     f"{c.verdict.value} | {c.violation:.4f} | {c.seconds:.2f} |")
    wrong = [c for c in cases if c.verdict is not c.truth]
    false_avoidable = sum(c.truth is Verdict.INFEASIBLE for c in wrong)
    summary = (f"{len(cases)} labelled cases: {len(wrong)} disagreements ({false_avoidable} false 'avoidable', "
               f"{len(wrong) - false_avoidable} false 'unavoidable').")
    text = "# Feasibility certificate accuracy\n\n" + summary + "\n\n" + "\n".join(lines) + "\n"
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "certificate_accuracy.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
