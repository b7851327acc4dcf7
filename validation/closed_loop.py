"""One scenario in closed loop against the MuJoCo plant, scored.

The loop is short: the controller (any object speaking controller.protocol, built from a preset or
a `package.module:Class`) steps on the measured state; its input is held (zero-order) over the
step's dt, rounded to the physics timestep; observers (validation.observers: contacts, telemetry,
video, Rerun) see every physics piece. The controller is told the scene's current and the faults
the scenario declares known; nothing else about the plant (its fluid model, contact, joint
friction, the mismatch) is shared.

Latency (`latency`, "none" by default: the plant waits for the controller). With a number of
seconds L each step's input reaches the thrusters L after its state was sampled, and the controller
is told L (Task.latency) so that it can plan for it; "measured" uses each step's own wall-clock time
(outcomes then depend on the machine and its load). "@MODES"
(e.g. "0.1@II,III") delays only the steps computed in those modes (the controller is then told no
delay). A step whose computation takes longer than L is an overrun, counted per mode
(Summary.solve_time, StepRecord.overrun). Meanwhile the actuators go on as a vehicle's would: the
acting input for what is left of its period (one period of its step from its arrival), then the
inputs its step committed in advance (below), one period each. Under a fixed L up to the period
that is the previous input throughout; a measured delay longer than the rest of the period, or a
delayed step after an undelayed one, plays the committed rows.

The inputs committed in advance by the last accepted step: the next rows of its plan
(StepInfo.u_pred, whose first row is the input it returned, then StepInfo.commit_after), and its
last input held once the plan runs out (a controller without a plan: its last input).

Strict real time (":strict" after a number of seconds, `--strict`): an overrun's answer is
discarded, as if its computation had been cut at L, and the next committed input is applied instead
for one period of the last accepted step, one further row per consecutive overrun. The controller
is told through the protocol's optional `late(u)`, with the input applied.

A measured delay and strict real time run no faster than real time: each step starts no earlier in
wall-clock time than its sample time after the first step's end, so that work a controller does
between its steps (a helper process) gets the time a vehicle would give it.

The verdict counts damage as any contact but the end-effector tip's: the paper's strategy lets the
tip, and only the tip, touch. A stowed arm that hits the wall before the hull spares the hull but is
still a collision ("arm contact"), and a tip whose peak normal force exceeds the parameter file's
`tip_force_limit` is a "tip overload".
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: headless rendering

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

from controller.feasibility import Certificate
from controller.protocol import Controller, KnownFault, StepInfo, Task, label
from controller.switching import Mode, SwitchReason
from uvms.params import UVMSParams
from uvms.scene import Scene
from uvms_mj.build import HULL
from uvms_mj.plant import Plant
from validation import manifest, presets
from validation import mismatch as mismatches
from validation.observers import ContactTally, Observer, Telemetry, Video, main_plane
from validation.scenarios import Scenario
from validation.setup import build_plant, initial_state, reference, wall_x  # noqa: F401
from validation.summary import ModeTiming, StepRecord, Summary


class Outcome(Enum):
    """A run's verdict: what touched an obstacle besides the end-effector tip, or how hard the tip did."""

    SUCCESS = "success"
    TIP_OVERLOAD = "tip overload"
    ARM_CONTACT = "arm contact"
    HULL_CONTACT = "hull contact"


def judge(hull_impulse: float, hull_peak: float, link_impulse: float, tip_peak: float,
          tip_limit: float = np.inf, hull_planes: tuple[str, ...] = ()) -> tuple[Outcome, str]:
    """Verdict and reason from the summed contact-impulse magnitudes [N s] of the hull and of the arm
    links other than the tip, the peak normal forces [N] of the hull and of the tip, the force the
    tip may take [N] (worst first: hull, other links, tip overload) and the planes the hull touched."""
    if hull_impulse > 0.0:
        where = f" the {' and the '.join(hull_planes)}" if hull_planes else ""
        return Outcome.HULL_CONTACT, (f"the hull touched{where} with {hull_impulse:.3f} N s of impulse, "
                                      f"peak {hull_peak:.0f} N")
    if link_impulse > 0.0:
        return Outcome.ARM_CONTACT, f"an arm link other than the end-effector touched with {link_impulse:.3f} N s"
    if tip_peak > tip_limit:
        return Outcome.TIP_OVERLOAD, f"only the end-effector touched, but with a peak of {tip_peak:.0f} N, over its " \
                                     f"limit of {tip_limit:.0f} N"
    if tip_peak > 0.0:
        return Outcome.SUCCESS, f"only the end-effector touched (peak {tip_peak:.0f} N)"
    return Outcome.SUCCESS, "nothing touched an obstacle"


VIDEO_FPS = 25
MEASURED = "measured"


def _pieces(duration: float, ts: float, longest: float) -> list[float]:
    """`duration` [s] in near-equal pieces, each a multiple of the physics timestep ts and at most
    `longest` (a long delay keeps the telemetry's and the video's rate); [] below ts / 2."""
    steps = round(duration / ts)
    if steps < 1:
        return []
    bounds = np.linspace(0, steps, int(np.ceil(duration / longest - 1e-9)) + 1).round().astype(int)
    return [int(n) * ts for n in np.diff(bounds)]


STRICT = ":strict"


@dataclass(frozen=True)
class Latency:
    """A computation delay (module docstring)."""

    seconds: float | None  # the same for every step; None: each step's own wall-clock time ("measured")
    modes: frozenset[Mode] = frozenset(Mode)  # the modes whose steps are delayed (the braking baseline: always)
    strict: bool = False  # an overrun's answer is discarded for the committed input

    @property
    def told(self) -> float:
        """The delay the controller is told to plan for [s] (Task.latency): L when every step is
        delayed by it, else 0."""
        return self.seconds if self.seconds is not None and self.modes == frozenset(Mode) else 0.0


def parse_latency(spec: str) -> Latency:
    """The computation delay from its spec: "none" (0 s), "measured", or a number of seconds >= 0,
    optionally followed by "@" and the comma-separated modes whose steps it delays (default: all),
    then optionally ":strict" (a number of seconds > 0 only)."""
    allowed = (f"allowed: none, {MEASURED}, or a number of seconds >= 0, optionally @MODES such as @II,III, "
               f"then optionally {STRICT} after a number of seconds > 0")
    strict = spec.endswith(STRICT)
    delay, at, modes = spec.removesuffix(STRICT).partition("@")
    if at and not modes:
        raise ValueError(f"latency {spec!r}: no mode after @; {allowed}")
    if delay == "none":
        value: float | None = 0.0
    elif delay == MEASURED:
        value = None
    else:
        try:
            value = float(delay)
        except ValueError:
            value = -1.0
        if not (0.0 <= value < np.inf):
            raise ValueError(f"latency {spec!r}; {allowed}")
    try:
        chosen = frozenset(Mode(m) for m in modes.split(",")) if modes else frozenset(Mode)
    except ValueError:
        raise ValueError(f"latency {spec!r}: unknown mode; {allowed}") from None
    if strict and not (value is not None and value > 0.0):
        raise ValueError(f"latency {spec!r}: strict needs a delay of seconds > 0; {allowed}")
    return Latency(value, chosen, strict)


def certificate_row(c: Certificate | None) -> dict | None:
    """A step's feasibility certificate for summary.json: the verdict, its evidence, the minimum
    violation [m] (null: IPOPT failed, which counts as F empty, or the screens alone decided) and
    the time [s]."""
    if c is None:
        return None
    return {"verdict": c.verdict.value, "method": c.method.value,
            "violation": c.violation if np.isfinite(c.violation) else None, "seconds": c.solve_time}


def switches(reasons: Sequence[Enum | str | None]) -> str:
    """"n (k by solver failure)" from the steps' switch reasons (None: no switch): the switches from
    Mode I to Mode II, and how many of them came from an IPOPT failure on the certificate's
    minimum-violation problem."""
    made = [label(r) for r in reasons if r is not None]
    return f"{len(made)} ({made.count(SwitchReason.SOLVER_FAILURE.value)} by solver failure)"


def task_of(sc: Scenario, params: UVMSParams, scene: Scene, latency: float = 0.0, wall_clock: bool = False) -> Task:
    """What the controller is told about the scenario (controller.protocol.Task), with the delay
    [s] its inputs reach the thrusters after their state's sample and whether the loop runs at the
    wall clock's pace."""
    h0, _ = initial_state(params, sc)
    ref = reference(params, sc)
    known = tuple(KnownFault(f.thrusters, f.at) for f in sc.faults if f.known and f.mode == "dead")
    return Task(name=sc.name, params=params, scene=scene, h0=h0, reference=ref if callable(ref) else lambda t: ref,
                known_faults=known, duration=sc.duration, latency=latency, wall_clock=wall_clock)


def make_folders(*paths: Path | None) -> None:
    """Create the output folders (None: skipped); one line naming the path if one cannot be made."""
    for path in paths:
        if path is not None:
            try:
                path.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                raise ValueError(f"output path {path}: {e.strerror}; allowed: a writable folder") from None


def run(sc: Scenario, controller: str | Controller = "switching", ctl: dict[str, Any] | None = None,
        mismatch: str = mismatches.DEFAULT, seed: int = 0, latency: str = "none", out: Path | None = None,
        video: Path | None = None, record: Path | None = None, plots: Path | None = None,
        observers: Sequence[Callable[[Plant], Observer]] = ()) -> Summary:
    """Run one scenario and score it; the summary is also written to out/summary.json.

    Args:
        sc: the scenario.
        controller: a preset of assets/presets.toml, a `package.module:Class`, or a controller object
            (controller.protocol; its `reset` is called here).
        ctl: dotted overrides of the controller's settings (e.g. {"mode3.horizon": 10}).
        mismatch: the plant-versus-controller mismatch spec or a name of validation.mismatch.NAMED
            ("" for none) ...
        seed: ... and the seed of its draw.
        latency: the computation delay (parse_latency; the module's docstring).
        out, video, record, plots: where to write summary.json, an MP4, a Rerun .rrd, the figures.
        observers: factories of further observers (validation.observers), each called with the plant.
    """
    if isinstance(controller, str):
        resolved = presets.resolve(controller, ctl)
        ctl_obj = presets.build(resolved)
    else:
        if ctl:
            raise ValueError("ctl overrides with a controller object; allowed: a preset name with ctl, or an object")
        resolved, ctl_obj = presets.of_object(controller), controller
    spec = parse_latency(latency)
    mismatch = mismatches.resolve(mismatch)
    make_folders(out, video.parent if video else None, record.parent if record else None, plots)
    params, scene, plant, drawn = build_plant(sc, mismatch, seed)
    task = task_of(sc, params, scene, spec.told, spec.strict or spec.seconds is None)
    plant.reset(task.h0)
    task = replace(task, trim=plant.trim_weight() + drawn.get("trim", 0.0))
    ctl_obj.reset(task)
    tally, telemetry = ContactTally(plant), Telemetry(plant)
    watching: list[Observer] = [tally, telemetry, *(make(plant) for make in observers)]
    if video is not None:
        watching.append(Video(plant, video, VIDEO_FPS))
    recording = None
    if record is not None:
        from validation.recording import RunRecording
        recording = RunRecording(record, plant, params, scene.water, f"{sc.name}-{resolved.name}-{seed}")
        recording.describe(scenario={"name": sc.name, **sc.to_data()}, controller=resolved.name,
                           settings=resolved.settings_dict(),
                           overrides=resolved.overrides, mismatch={"spec": mismatch, "seed": seed, "values": drawn},
                           latency=latency)
        watching.append(recording)
    ts, chunk = plant.model.opt.timestep, 0.1
    steps: list[StepRecord] = []
    origin = manifest.start() if out is not None else None
    wall_clock, u_prev, paced_from = time.perf_counter(), None, None
    committed = Committed(ts)
    sense = getattr(ctl_obj, "sense", None)  # the protocol's optional wrist force/torque sensor
    late = getattr(ctl_obj, "late", None)  # the protocol's optional notice of a discarded answer
    wrist, sensed_for = np.zeros(6), 0.0  # the wrist's contact impulse [N s, N m s] and its period [s]
    try:
        while plant.t < sc.duration - 1e-9:
            t = plant.t
            if (spec.seconds is None or spec.strict) and paced_from is not None:  # no faster than real time
                time.sleep(max(0.0, t - (time.perf_counter() - paced_from)))
            if sense is not None and sensed_for > 0.0:
                sense(wrist / sensed_for)
            wrist, sensed_for = np.zeros(6), 0.0
            t0 = time.perf_counter()
            u, info = ctl_obj.step(plant.state(), t)
            computed = time.perf_counter() - t0
            _check_step(resolved.name, u, info, params.n_inputs)
            paced_from = time.perf_counter() if paced_from is None else paced_from
            mode = label(info.mode)
            undelayed = u_prev is None or (mode in {m.value for m in Mode} and Mode(mode) not in spec.modes)
            overrun = not undelayed and spec.seconds not in (None, 0.0) and computed > spec.seconds
            delay = 0.0 if undelayed else round((computed if spec.seconds is None else spec.seconds) / ts) * ts
            meanwhile = committed.meanwhile(u_prev, delay)
            if overrun and spec.strict:
                u, period = committed.take(u_prev)
                if late is not None:
                    late(u.copy())
                info = replace(info, dt=period, fallback=LATE, h_pred=None, u_pred=None, commit_after=None,
                               contact_force=None)
            else:
                committed.accept(info)
            dt = max(ts, round(info.dt / ts) * ts)
            segments = [*meanwhile, (u, dt - delay)]
            committed.left = min(spec.told if undelayed else delay, dt)  # the first input acts until the told L
            for u_seg, duration in [(us, piece) for us, d in segments for piece in _pieces(d, ts, chunk)]:
                t_seg = plant.t
                report = plant.step(u_seg, duration)
                wrist, sensed_for = wrist + report.wrist_impulse, sensed_for + duration
                for obs in watching:
                    obs.observe(t_seg, report, info, u_seg)
            u_prev = u
            steps.append(_record(t, max(dt, delay), delay, info, computed, overrun))
        summary = _summarize(sc, resolved, mismatch, seed, drawn, latency, spec, params, scene, plant, task, tally,
                             steps, time.perf_counter() - wall_clock)
        if recording is not None:
            recording.verdict(summary.verdict, summary.reason)
    finally:
        for obs in watching:
            obs.close()
    if out is not None:
        summary.write(out / "summary.json")
        manifest.write(out, {"scenario": summary.scenario, "controller": summary.controller,
                             "controller_settings": summary.controller_settings, "mismatch": summary.mismatch,
                             "latency": latency}, summary.wall_clock_s, started=origin)
    if plots is not None:
        from validation import plots as figures
        names = {"thrusters": [th.name for th in params.thrusters], "joints": [lk.name for lk in params.arm.links]}
        figures.write(telemetry.arrays(), names, plots)
    return summary


def _check_step(name: str, u: np.ndarray, info: StepInfo, n_inputs: int) -> None:
    """One line naming the controller when its step is not (n_inputs finite numbers, a StepInfo with
    a finite dt > 0)."""
    u = np.asarray(u)
    if u.shape != (n_inputs,) or not np.all(np.isfinite(u)):
        raise ValueError(f"controller {name} returned an input of shape {u.shape} or non-finite entries; allowed: "
                         f"{n_inputs} finite numbers (thruster forces N, joint torques N m)")
    if not isinstance(info, StepInfo) or not (np.isfinite(info.dt) and info.dt > 0):
        raise ValueError(f"controller {name} returned {type(info).__name__} with dt {getattr(info, 'dt', None)}; "
                         "allowed: a controller.protocol.StepInfo with a finite dt > 0 [s]")


LATE = "committed input (the step overran its latency)"


class Committed:
    """The inputs a controller committed in advance (the module docstring's strict real time and
    actuators): the rest of its last accepted step's plan, that step's period, and what is left of
    the acting input's period at the next sample [s]."""

    def __init__(self, ts: float) -> None:
        self.ts = ts  # the physics timestep [s]: periods are its multiples
        self.inputs: list[np.ndarray] = []
        self.period = 0.0
        self.left = 0.0

    def meanwhile(self, acting: np.ndarray | None, delay: float) -> list[tuple[np.ndarray, float]]:
        """The inputs over a step's delay [s] and for how long each [s]: `acting` for what is left of
        its period, then the committed rows (take), each for a period; [] without a delay."""
        pieces = [(acting, min(self.left, delay))] if delay > 0.0 and self.left > 0.0 else []
        covered = sum(d for _, d in pieces)
        while covered < delay - 1e-9:
            u, period = self.take(acting)
            pieces.append((u, min(period, delay - covered)))
            covered += period
        return pieces

    def accept(self, info: StepInfo) -> None:
        """A step's answer is applied: its plan's later rows, then its rows past the plan's end
        (StepInfo.commit_after), are what it commits to."""
        plan = [] if info.u_pred is None else list(np.asarray(info.u_pred, float)[1:])
        plan += [] if info.commit_after is None else list(np.asarray(info.commit_after, float))
        self.inputs = [np.asarray(row, float) for row in plan]
        self.period = max(self.ts, round(float(info.dt) / self.ts) * self.ts)

    def take(self, last: np.ndarray) -> tuple[np.ndarray, float]:
        """The input to apply for an overrun, and for how long [s]: the plan's next row, else `last`."""
        u = self.inputs.pop(0) if self.inputs else np.asarray(last, float)
        if not self.inputs:
            self.inputs = [u]
        return u, self.period


def _record(t: float, period: float, delay: float, info: StepInfo, computed: float,
            overrun: bool = False) -> StepRecord:
    cert = info.certificate
    return StepRecord(t=t, dt=period, delay=delay, mode=label(info.mode), status=label(info.status),
                      fallback=label(info.fallback), compute_time=computed, solve_time=float(info.solve_time),
                      ocp_time=float(info.ocp_time), iterations=int(info.iterations), horizon=int(info.horizon),
                      certificate=certificate_row(cert) if isinstance(cert, Certificate) else None,
                      switch=label(info.switch),
                      impact_force=None if info.impact_force is None else float(info.impact_force),
                      overrun=overrun)


def _summarize(sc: Scenario, resolved: presets.Resolved, mismatch: str, seed: int, drawn: dict, latency: str,
               spec: Latency, params: UVMSParams, scene: Scene, plant: Plant, task: Task, tally: ContactTally,
               steps: list[StepRecord], wall_clock: float) -> Summary:
    h, n = plant.state(), params.n_joints
    ref = task.reference(plant.t)
    modes = [s.mode for s in steps]
    per_mode = {}
    for m in dict.fromkeys(modes):
        times = [s.compute_time for s in steps if s.mode == m]
        per_mode[m] = ModeTiming(len(times), float(np.median(times)), float(np.percentile(times, 95)),
                                 float(np.max(times)), float(np.percentile(times, 99)),
                                 sum(s.overrun for s in steps if s.mode == m))
    c = tally.totals()
    wall = main_plane(scene.planes)
    hull_geoms = [i for i, g in enumerate(plant.geom_names) if g.startswith(HULL)]
    outcome, reason = judge(c.hull_impulse, c.hull_peak, c.link_impulse, c.tip_peak, params.arm.tip_force_limit,
                            c.hull_planes)
    overruns = sum(s.overrun for s in steps)
    return Summary(
        scenario={"name": sc.name, **sc.to_data()}, controller=resolved.name,
        controller_settings=resolved.settings_dict(),
        controller_overrides=dict(resolved.overrides),
        mismatch={"spec": mismatch, "seed": seed, "values": drawn, "told_trim": task.trim}, latency=latency,
        verdict=outcome.value, reason=reason,
        modes=[m for k, m in enumerate(modes) if k == 0 or modes[k - 1] != m],
        timeline=[[s.t, s.mode] for k, s in enumerate(steps) if k == 0 or modes[k - 1] != s.mode],
        min_distance={g: {p.name: float(c.min_distance[i, j]) for j, p in enumerate(scene.planes)}
                      for i, g in enumerate(plant.geom_names)},
        min_hull_distance=float(c.min_distance[hull_geoms].min()) if hull_geoms else None,
        hull_contact_impulse=c.hull_impulse, hull_peak_contact_force=c.hull_peak, ee_peak_contact_force=c.tip_peak,
        link_contact_impulse=c.link_impulse,
        max_total_thrust_along_wall_normal=params.max_thrust_along(-scene.planes[wall].normal),
        final_task_error=float(np.linalg.norm(h[:3] - ref[:3])), final_joint_angles=h[6:6 + n].tolist(),
        solve_time=per_mode, fallbacks=sum(s.fallback != "none" for s in steps),
        switches=switches([s.switch for s in steps]), overruns=overruns, simulated_s=plant.t,
        wall_clock_s=wall_clock, steps=steps)
