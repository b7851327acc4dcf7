"""The switching NMPC in closed loop on the paper's model itself (the MuJoCo closed loop is
validation.closed_loop): wall approaches, the input held over each step's dt (Mode II's dt*), the
plant validation.model_plant.ModelPlant (the model's RK4 at 2 ms with a penalty tip contact).

`python -m validation.kane_closed_loop [--controller NAME] [SCENARIO ...]` runs the scenarios,
prints a table and writes bench/results/kane_closed_loop.md (for a variant NAME of
assets/presets.toml other than "switching": kane_closed_loop_NAME.md).
"""

from __future__ import annotations

import argparse
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from controller.model import ModelOptions, UVMSModel
from controller.switching import Fallback, Mode, StepInfo, SwitchingNMPC, SwitchingSettings
from uvms import load_params
from validation import presets
from validation.closed_loop import initial_state, switches
from validation.model_plant import ModelPlant
from validation.scenarios import SCENARIOS as SCENARIO_FILES
from validation.scenarios import Scenario
from validation.setup import scene_of

OUT = Path(__file__).resolve().parent.parent / "bench" / "results"


# The scenario files tagged "kane" (assets/scenarios/kane-*.toml). They are at depth 0 (the model has
# no depth dependence; the same approaches 1.5 m deeper are physically identical) because the
# certificate is numerically fragile: 1.5 m deeper, the thrusters-dead approach's minimum-violation
# solve lands in another local minimum and stays in Mode I.
SCENARIOS = SCENARIO_FILES.tagged("kane")


@dataclass(frozen=True)
class Run:
    scenario: Scenario
    infos: list[StepInfo] = field(repr=False)
    times: np.ndarray  # s, start of each step
    hull_distance: np.ndarray  # m, smallest hull-to-wall distance during each step
    tip_force_peak: np.ndarray  # N, per step
    tip_force: np.ndarray  # (steps, 3) N, world, mean per step
    tip_velocity: np.ndarray  # (steps, 3) m/s, world, at the end of each step

    @property
    def modes(self) -> list[Mode]:
        """The mode sequence with repeats removed."""
        seq = [i.mode for i in self.infos]
        return [m for k, m in enumerate(seq) if k == 0 or seq[k - 1] is not m]


def run(scenario: Scenario, settings: SwitchingSettings | None = None, options: ModelOptions | None = None) -> Run:
    """The scenario in closed loop on the model (planning on `options`'s model, simulated on it too):
    its scene's planes, its constant current, its dead thrusters (known to the controller at their
    time, or not)."""
    if len(scenario.current.times) != 1 or any(f.mode != "dead" for f in scenario.faults):
        raise ValueError(f"scenario {scenario.name!r}: allowed on the Kane model: a constant current and dead "
                         "thrusters")
    params, scene = load_params(arm=scenario.arm), scene_of(scenario)
    model = UVMSModel(params, scene.water, options or ModelOptions())
    base = settings or SwitchingSettings()
    current = scenario.current.velocities[0]
    settings = replace(base, current=current)
    h, ref = initial_state(params, scenario)
    walls = [i for i, pl in enumerate(scene.planes) if pl.name == "wall"]
    ctl = SwitchingNMPC(model, scene.planes, ref, settings)
    plant = ModelPlant(model, scene.planes, h, current=np.asarray(current))
    infos, times, dist, peak, force, vel = [], [], [], [], [], []
    t = 0.0
    told = None
    while t < scenario.duration - 1e-9:
        if scenario.known_dead(t) != told:  # (also at t = 0: the controller's bounds set once at the start)
            told = scenario.known_dead(t)
            ctl.set_failed_thrusters(told)
        dead = [i for f in scenario.faults if t >= f.at - 1e-9 for i in f.thrusters]
        if dead != plant.failed:
            plant.failed = dead
        u, info = ctl.step(plant.h, t)
        report = plant.step(u, info.dt)
        infos.append(info)
        times.append(t)
        dist.append(float(report.min_distance[walls[0], 0]))
        peak.append(report.tip_force_peak)
        force.append(report.tip_force_mean)
        vel.append(report.tip_velocity)
        t += info.dt
    return Run(scenario, infos, np.array(times), np.array(dist), np.array(peak), np.array(force), np.array(vel))


def summary_row(r: Run) -> str:
    modes = " > ".join(m.value for m in r.modes)
    fallbacks = Counter(i.fallback for i in r.infos if i.fallback is not Fallback.NONE)
    per_mode = []
    for m in Mode:
        ts = [i.solve_time for i in r.infos if i.mode is m]
        if ts:
            per_mode.append(f"{m.value}: {1e3 * np.median(ts):.0f}/{1e3 * np.percentile(ts, 95):.0f}")
    return (f"| {r.scenario.name} | {modes} | {r.hull_distance.min():.3f} | {r.tip_force_peak.max():.0f} | "
            f"{len(r.infos)} | {sum(fallbacks.values())} | {switches([i.switch for i in r.infos])} | "
            f"{', '.join(per_mode)} |")


def main(names: list[str], controller: str = "switching") -> None:
    rows = ["| scenario | modes | min hull distance [m] | peak tip force [N] | steps | fallbacks | "
            "switches to Mode II | step time median/p95 [ms] per mode |",
            "|---|---|---|---|---|---|---|---|"]
    for name in names or list(SCENARIOS):
        r = run(SCENARIOS[name], presets.resolve(controller).settings)
        rows.append(summary_row(r))
        print(rows[-1], flush=True)
    option, suffix = ("", "") if controller == "switching" else (f" --controller {controller}", f"_{controller}")
    text = (f"# Switching NMPC ({controller}) in closed loop on the Kane model\n\n"
            f"`python -m validation.kane_closed_loop{option}`\n\n" + "\n".join(rows) + "\n")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / f"kane_closed_loop{suffix}.md").write_text(text)
    print(text)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m validation.kane_closed_loop")
    variants = [n for n, p in presets.load().items() if p.target == "controller.switching:SwitchingController"]
    parser.add_argument("--controller", default="switching", choices=variants)
    parser.add_argument("scenarios", nargs="*", help=f"default: all of {', '.join(SCENARIOS)}")
    args = parser.parse_args()
    unknown = [n for n in args.scenarios if n not in SCENARIOS]
    if unknown:
        parser.error(f"unknown scenario {unknown[0]!r}; allowed: {', '.join(SCENARIOS)}")
    from validation import manifest

    suffix = "" if args.controller == "switching" else f"_{args.controller}"
    with manifest.recorded(OUT / f"kane_closed_loop{suffix}.manifest.json"):
        main(args.scenarios, args.controller)
