"""Accuracy of Mode I's feasibility certificate (issue 4) on labelled wall approaches.

Two ground truths, side by side:
- the model's maximum-braking rollout (controller.feasibility.FeasibilityTest.braking_rollout:
  attitude held, the joints held), evaluated at each speed (the issue's definition);
- Mode I's feasible set F itself, decided with more solver effort than a certificate spends
  (f_feasible): the braking rollout, else, from several starts (the braking rollout; coasting with
  zero inputs; the points of F the certificates found at this speed; the two points of F found
  for the same approach at the nearest other speeds, a continuation in speed), the start itself,
  the minimum-violation problem and the line-search SQP (FeasibilityTest.search_plan). A zero
  minimum violation or a plan that satisfies the OCP's constraints is a feasible point of the
  OCP, a proof that F is not empty; "empty" means no start found one: strong evidence, not a
  proof (the problem is not convex). Labels that are not monotone in speed on an approach are
  reported: they show that this evidence failed somewhere.
The braking rollout is not the model's best braking: the OCP also swings the arm (its reaction
moves the hull) and tilts the hull to use the vertical thrusters, so it avoids walls the rollout
hits. F's threshold speed v* (threshold_speed: a grid, then bisection, on the second truth, per
approach: level hull facing the wall, arm stowed, its closest body `gap` m from the wall, velocity
`angle` deg off the wall's normal) sets the speeds 0.5, 0.8, 0.9, 1.1, 1.25 and 1.5 v* (outside the +-5% band); each is
labelled by both truths at that speed and given to four certificates as the closed loop's first
Mode I step asks them (no previous plan; Mode I's fresh real-time plan as a screen): the default
(the braking rollout, Mode I's plan, then the minimum-violation problem from the rollout), the
warm-started one (the minimum-violation problem from Mode I's plan), the one with the optional
line-search SQP screen (controller.feasibility says why both are off by default) and the screens
alone at 1.5 cm of clearance ("switching-screens": no IPOPT; not certified counts as unavoidable).
The same four certificates and both truths are also given the issue's own set: head-on approaches
with gaps of 15 and 20 cm and an oblique one, 20 cm at 30 deg, at the same factors of the braking
rollout's threshold speed (its braking limit, braking_threshold: 1.3, 1.5 and 1.9 m/s). The
rollout's labels are not monotone in speed on most other approaches (at 10 cm head-on: feasible at
0.05-0.4 m/s, not at 0.45-0.55, again at 0.6-1.05 m/s; the attitude hold and the pitch that braking
induces change which body comes closest; of gaps 10-30 cm at 10-45 deg only 20 cm at 30 and 45 deg
and 25 cm at 10-30 deg have a single limit within 2.5 m/s), so those have no braking limit and are
refused.
F is the OCP's, on the implicit midpoint rule at its nodes: the table also gives the smallest
clearance of the default certificate's minimum-violation plan (when it has one) under fine RK4
(10 substeps an interval), which shows how far the true trajectory between and at the nodes
departs from the discretized one.

`python -m validation.certificate_accuracy` prints the tables and writes
bench/results/certificate_accuracy.md (about 15 min).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from controller.feasibility import MIN_VIOLATION_MAX_ITER, Certificate, FeasibilityTest, Method, Verdict
from controller.mode1 import ModeIOCP
from controller.model import UVMSModel
from controller.rollouts import simulate
from uvms import load_params, load_scene
from validation.closed_loop import SCREEN_MARGIN, wall_x
from validation.closed_loop import SEARCH_ITERATIONS as SEARCH

FACTORS = (0.5, 0.8, 0.9, 1.1, 1.25, 1.5)
OUT = Path(__file__).resolve().parent.parent / "bench" / "results"


@dataclass(frozen=True)
class Verdicts:
    """One certificate's answer on one case."""

    verdict: Verdict
    method: Method
    violation: float  # m, the minimum violation (inf: IPOPT failed; 0 when a screen certified)
    seconds: float  # s, with the fresh Mode I solve it asked for


@dataclass(frozen=True)
class Case:
    gap: float  # m
    angle: float  # deg between the velocity and the wall's inward normal
    speed: float  # m/s
    threshold: float  # m/s, F's threshold speed
    rollout: Verdict  # the braking rollout's label at this speed
    truth: Verdict  # F's label at this speed (f_feasible)
    default: Verdicts  # the default certificate
    fine_clearance: float  # m, its minimum-violation plan under fine RK4 (nan when a screen certified)
    warm: Verdicts  # with SwitchingSettings.certificate_warm_start
    searched: Verdicts  # with the line-search SQP screen
    screened: Verdicts  # the screens alone, at 1.5 cm ("switching-screens"; not certified counts as infeasible)


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


def rollout_feasible(test: FeasibilityTest, h: np.ndarray) -> bool:
    hs, _ = test.braking_rollout(h)
    return test.min_clearance(hs) >= test.settings.distance_margin


def fine_clearance(test: FeasibilityTest, h0: np.ndarray, us: np.ndarray, substeps: int = 10) -> float:
    """Smallest clearance [m] of inputs us (N, nu) held over the intervals from h0, by RK4 in
    `substeps` per interval, every substep checked."""
    h, worst, dt = np.asarray(h0, float), np.inf, test.settings.dt / substeps
    for u in us:
        for _ in range(substeps):
            h = test.model.step(h, u, dt)
            worst = min(worst, float(np.asarray(test.problem._clearance(h)).min()))
    return worst


def f_feasible(test: FeasibilityTest, h: np.ndarray, ref: np.ndarray,
               others: Sequence[np.ndarray] = ()) -> np.ndarray | None:
    """F's label as the inputs (N, nu) of a point of F, or None when no start finds one: the braking
    rollout, else, from each start (the braking rollout, coasting, then `others`: inputs found
    elsewhere, re-simulated from h), the start itself when it is a point of F, a zero minimum
    violation, or a point of F from the line-search SQP (FeasibilityTest.search_plan)."""
    hs, us = test.braking_rollout(h)
    if test.min_clearance(hs) >= test.settings.distance_margin:
        return us
    p, N, dt = test.problem, test.settings.horizon, test.settings.dt
    zero = np.zeros((N, p.nu))
    starts = [(hs, us), (simulate(test.model, h, zero, dt), zero)]
    starts += [(simulate(test.model, h, u, dt), u) for u in others]
    for start in starts:
        if test.plan_is_feasible(*start):
            return start[1]
        sol = p.solve(h, ref, guess=p.guess_from_rollout(*start))
        if sol.status.usable and float(np.sum(sol.slack)) <= test.tolerance:
            return sol.u
        plan = test.search_plan(h, ref, start)
        if plan is not None:
            return plan.u
    return None


class Bank:
    """The points of F found for one approach, by speed: a continuation, so that a plan found at
    one speed starts the search at the nearest others."""

    def __init__(self, nearest: int = 2):
        self.plans: list[tuple[float, np.ndarray]] = []  # (m/s, inputs (N, nu))
        self.labels: list[tuple[float, bool]] = []  # every speed labelled [m/s], feasible or not
        self.nearest = nearest

    def near(self, speed: float) -> list[np.ndarray]:
        return [u for _, u in sorted(self.plans, key=lambda p: abs(p[0] - speed))[:self.nearest]]

    def label(self, test: FeasibilityTest, h: np.ndarray, ref: np.ndarray, speed: float,
              others: Sequence[np.ndarray] = ()) -> bool:
        """f_feasible with `others` and the nearest plans as extra starts; a point found joins."""
        found = f_feasible(test, h, ref, [*others, *self.near(speed)])
        if found is not None:
            self.plans.append((speed, found))
        self.labels.append((speed, found is not None))
        return found is not None


def threshold_speed(test: FeasibilityTest, gap: float, angle: float, bank: Bank, step: float = 0.05,
                    refine: int = 4) -> float:
    """F's threshold speed [m/s]: the bank's labels on a grid of `step` up to 1 m/s, ascending, so that
    each speed also starts from the points of F found at the speeds below it; then bisection between
    the largest feasible grid speed and the next. (A bisection from the start trusted a single
    infeasible label: one false 'empty' at its first midpoint put the threshold of an approach at
    0.5 m/s that is feasible at 0.75 m/s.) Within 1 m/s, so that 1.5 times the threshold stays
    within a BlueROV2's speeds (above about 1.8 m/s the model's quadratic drag makes feasibility
    non-monotone in speed)."""
    grid = np.arange(1, round(1.0 / step) + 1) * step
    feasible = [v for v in grid if bank.label(test, *approach(test, gap, angle, v), v)]
    lo = max(feasible, default=0.0)
    if lo >= grid[-1]:
        raise ValueError(f"approach {gap} m, {angle} deg: F is not empty up to 1 m/s; allowed: approaches "
                         "whose threshold lies within 1 m/s (smaller gaps)")
    hi = lo + step
    for _ in range(refine):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if bank.label(test, *approach(test, gap, angle, mid), mid) else (lo, mid)
    return 0.5 * (lo + hi)


def label(ok: bool) -> Verdict:
    return Verdict.FEASIBLE if ok else Verdict.INFEASIBLE


def certify(test: FeasibilityTest, mode1: ModeIOCP, h: np.ndarray, ref: np.ndarray,
            minimum_violation: bool = True) -> tuple[Verdicts, Certificate, np.ndarray | None]:
    """A certificate's verdict as the closed loop's first Mode I step asks for it: no previous
    plan, and Mode I's fresh plan (its real-time SQP from h held, re-simulated by RK4) as the third
    screen; UNDECIDED (screens alone) counts as infeasible, as the switch takes it. Also the inputs
    (N, nu) of the point of F it found (None: none, or the braking rollout)."""
    plans = []

    def fresh() -> tuple[np.ndarray, np.ndarray] | None:
        sol = mode1.solve(h, ref)
        plans.append(sol.u)
        return (simulate(test.model, h, sol.u, test.settings.dt), sol.u) if sol.status.usable else None

    c = test(h, ref, fresh=fresh, minimum_violation=minimum_violation)
    found = None
    if c.verdict is Verdict.FEASIBLE:
        found = plans[-1] if c.method is Method.MODE_I_PLAN else c.solution.u if c.solution is not None else None
    verdict = Verdict.INFEASIBLE if c.verdict is Verdict.UNDECIDED else c.verdict
    return Verdicts(verdict, c.method, c.violation, c.solve_time), c, found


def braking_threshold(test: FeasibilityTest, gap: float, angle: float, step: float = 0.05, top: float = 2.5,
                      tol: float = 1e-3) -> float:
    """The braking rollout's threshold speed [m/s] (the issue's braking limit): its labels on a grid
    of `step` up to `top`, which must be monotone in speed, then bisection to `tol`."""
    grid = np.arange(1, round(top / step) + 1) * step
    ok = [rollout_feasible(test, approach(test, gap, angle, v)[0]) for v in grid]
    if ok != sorted(ok, reverse=True) or all(ok) or not any(ok):
        raise ValueError(f"approach {gap} m, {angle} deg: the braking rollout's labels on 0.05 to {top} m/s are not "
                         "feasible then infeasible; allowed: approaches with one braking limit within that range")
    k = ok.index(False)
    lo, hi = grid[k - 1], grid[k]
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if rollout_feasible(test, approach(test, gap, angle, mid)[0]) else (lo, mid)
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class Certificates:
    """The four certificates of `evaluate` and Mode I's real-time solver that gives them a fresh plan."""

    default: FeasibilityTest
    warm: FeasibilityTest
    searching: FeasibilityTest
    screens: FeasibilityTest
    mode1: ModeIOCP


def labelled(cs: Certificates, gap: float, angle: float, threshold: float, bank: Bank) -> list[Case]:
    """The cases of one approach at FACTORS times `threshold` [m/s]: both truths and the four verdicts."""
    rows = []
    for f in FACTORS:
        h, ref = approach(cs.default, gap, angle, f * threshold)
        (default, c, u1), (warmed, _, u2), (searched, _, u3) = (certify(t, cs.mode1, h, ref)
                                                                for t in (cs.default, cs.warm, cs.searching))
        screened = certify(cs.screens, cs.mode1, h, ref, minimum_violation=False)[0]
        truth = bank.label(cs.searching, h, ref, f * threshold, [u for u in (u1, u2, u3) if u is not None])
        fine = fine_clearance(cs.default, h, c.solution.u) if c.solution is not None else np.nan
        rows.append(Case(gap, angle, f * threshold, threshold, label(rollout_feasible(cs.default, h)), label(truth),
                         default, fine, warmed, searched, screened))
    return rows


def evaluate(approaches=((0.02, 0.0), (0.03, 0.0), (0.01, 30.0), (0.02, 30.0)),
             braking_approaches=((0.15, 0.0), (0.2, 0.0), (0.2, 30.0)), max_iter: int = MIN_VIOLATION_MAX_ITER,
             ) -> tuple[list[Case], list[Case], list[str]]:
    """The four certificates on each labelled case around F's threshold (`approaches`) and around
    the braking rollout's (`braking_approaches`: the issue's set), and the approaches whose F labels
    are not monotone in speed. F's labels use every way any certificate finds a feasible point, and
    more starts. The gaps (m, closest body to the wall) around F's threshold are small so that every
    threshold lies within the threshold search's 1 m/s (at 0.05 m head-on and at 0.03 m and 30 deg,
    F is not empty up to 1 m/s)."""
    params, scene = load_params(), load_scene()
    model = UVMSModel(params, scene.water)
    test = FeasibilityTest(model, scene.planes, max_iter=max_iter)
    cs = Certificates(test, FeasibilityTest(model, scene.planes, warm_start=True, max_iter=max_iter),
                      FeasibilityTest(model, scene.planes, search_iterations=SEARCH, max_iter=max_iter),
                      FeasibilityTest(model, scene.planes, replace(test.settings, distance_margin=SCREEN_MARGIN),
                                      max_iter=max_iter),
                      ModeIOCP(model, scene.planes, test.settings))
    cases, braking, non_monotone = [], [], []
    for group, where in ((approaches, cases), (braking_approaches, braking)):
        for gap, angle in group:
            bank = Bank()
            v = (threshold_speed(cs.searching, gap, angle, bank) if where is cases
                 else braking_threshold(test, gap, angle))
            where += labelled(cs, gap, angle, v, bank)
            labels = [ok for _, ok in sorted(bank.labels)]  # the threshold search's and the cases' labels
            if labels != sorted(labels, reverse=True):
                non_monotone.append(f"{gap:g} m, {angle:g} deg")
    return cases, braking, non_monotone


def table(cases: Sequence[Case], threshold: str) -> list[str]:
    lines = [f"| gap [m] | angle [deg] | {threshold} [m/s] | speed / it | braking rollout | F | "
             "certificate | its evidence | min. violation [m] | plan's clearance, fine RK4 [m] | time [s] | "
             "warm-started | its evidence | time [s] | with the search screen | its evidence | time [s] | "
             "screens alone (1.5 cm) | its evidence | time [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in cases:
        d, w, s, o = c.default, c.warm, c.searched, c.screened
        lines.append(f"| {c.gap:g} | {c.angle:g} | {c.threshold:.3f} | {c.speed / c.threshold:.2f} | "
                     f"{c.rollout.value} | {c.truth.value} | {d.verdict.value} | {d.method.value} | "
                     f"{d.violation:.4f} | {c.fine_clearance:.4f} | {d.seconds:.2f} | {w.verdict.value} | "
                     f"{w.method.value} | {w.seconds:.2f} | {s.verdict.value} | {s.method.value} | {s.seconds:.2f} | "
                     f"{o.verdict.value} | {o.method.value} | {o.seconds:.2f} |")
    return lines


def summary(cases: Sequence[Case]) -> str:
    def errors(name: str, truth: str) -> str:
        wrong = [c for c in cases if getattr(c, name).verdict is not getattr(c, truth)]
        fa = sum(getattr(c, truth) is Verdict.INFEASIBLE for c in wrong)
        return f"{len(wrong)} disagreements ({fa} false 'avoidable', {len(wrong) - fa} false 'unavoidable')"

    def report(name: str, title: str) -> str:
        median = float(np.median([getattr(c, name).seconds for c in cases]))
        return (f"{title}: against F {errors(name, 'truth')}, against the braking rollout "
                f"{errors(name, 'rollout')}, median {median:.2f} s.")

    return " ".join((
        report("default", "The default certificate"),
        report("warm", "Warm-started (the minimum-violation problem from Mode I's fresh plan)"),
        report("searched", f"With the line-search screen ({SEARCH} iterations)"),
        report("screened", f"The screens alone, asking {100 * SCREEN_MARGIN:g} cm of clearance "
               "(\"switching-screens\"; not certified counts as unavoidable)")))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="The feasibility certificate on labelled approaches.")
    ap.add_argument("--max-iter", type=int, default=MIN_VIOLATION_MAX_ITER,
                    help=f"the minimum-violation problem's IPOPT iteration cap (default {MIN_VIOLATION_MAX_ITER}, "
                         "the controller's)")
    a = ap.parse_args(argv)
    if a.max_iter < 1:
        raise SystemExit(f"--max-iter {a.max_iter}; allowed: an integer >= 1")
    cases, braking, non_monotone = evaluate(max_iter=a.max_iter)
    default = a.max_iter == MIN_VIOLATION_MAX_ITER
    name = "certificate_accuracy.md" if default else f"certificate_accuracy_cap{a.max_iter}.md"
    capped = "" if default else (f"`python -m validation.certificate_accuracy --max-iter {a.max_iter}`: the "
                                            f"minimum-violation problem's IPOPT capped at {a.max_iter} iterations "
                                            f"instead of {MIN_VIOLATION_MAX_ITER}.\n\n")
    text = (
        "# Feasibility certificate accuracy\n\n" + capped +
        "Each certificate is asked as at the closed loop's first Mode I step (no previous plan, Mode I's fresh plan "
        "as a screen); every case lies outside the +-5% band around its set's threshold speed. F's labels (the "
        "threshold search's and the cases') are monotone in speed "
        + ("on every approach." if not non_monotone else f"except on {'; '.join(non_monotone)}.") +
        " Every way the certificates find a feasible point is also one of F's, so they cannot call an approach "
        "avoidable that F calls unavoidable; what the tables measure against F is the other error. The braking "
        "rollout is a weaker truth than F (the OCP also swings the arm and tilts the hull), so against it the "
        "error is false 'avoidable'.\n\n"
        f"## Around F's threshold speed v* ({len(cases)} cases)\n\n" + summary(cases) + "\n\n"
        + "\n".join(table(cases, "v* of F")) + "\n\n"
        f"## Around the braking rollout's threshold speed, the issue's braking limit ({len(braking)} cases)\n\n"
        + summary(braking) + "\n\n" + "\n".join(table(braking, "braking limit")) + "\n")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / name).write_text(text)
    print(text)


if __name__ == "__main__":
    main()
