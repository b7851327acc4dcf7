"""The switching NMPC against the MuJoCo plant (issue 5): one scenario, closed loop, scored.

A control period is the step's dt (dt_nom, or Mode II's dt* rounded to the physics timestep) with
the input held (zero-order) over MuJoCo's physics steps and the state measured from the plant. The
controller knows the scene's current at each step and is told of thruster failures when they happen;
nothing else about the plant (its fluid model, contact, joint friction) is shared.

Computation delay (`latency`, off by default): by default the plant waits for the controller, so a
step that takes 2 s to compute costs nothing. With a latency the step's input reaches the thrusters
that long after its state was sampled; the previous input acts meanwhile, and a step that takes
longer than its period delays the next sample until it is done (one computation at a time). The
first step's input acts from t = 0 (the run starts when the controller's first plan is ready).
"measured" uses each step's own wall-clock time on this machine (so outcomes depend on the machine
and its load), and the loop then runs no faster than real time (it waits before a step whose
sample time is still ahead of the wall clock), so that work the controller does in the background
(`switching-background`) takes as long in simulated time as it does in fact; a number of seconds
is the same for every step (deterministic). A suffix "@MODES" (e.g. "0.1@II,III") delays only the
steps computed in those modes, the others acting at once: which mode's delay costs what.

The verdict counts damage as any contact but the end-effector tip's: the paper's strategy lets the
tip, and only the tip, touch. A stowed arm that crashes into the wall before the hull does spares
the hull but is still a collision ("arm contact"), not a success. So is a tip whose peak normal force
in the plant exceeds the jaws' rating, the parameter file's `tip_force_limit` ("tip overload"; the
controller's Mode III bounds its planned force by the same number).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: headless rendering

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from enum import Enum
from functools import partial
from pathlib import Path

import numpy as np

from controller.feasibility import Certificate, Stop
from controller.model import ModelOptions, UVMSModel
from controller.rollouts import BrakingPolicy
from controller.sqp import QPMode
from controller.superellipsoid import DELTA
from controller.switching import Fallback, Mode, SwitchingNMPC, SwitchingSettings, SwitchReason
from uvms_mj.build import HULL, TIP_GEOM
from validation import mismatch as mismatches
from validation.scenarios import Scenario
from validation.setup import build_plant, current_profile, initial_state, max_thrust_along, reference, wall_x  # noqa: F401


class Outcome(Enum):
    """A run's verdict: what touched an obstacle besides the end-effector tip, or how hard the tip did."""

    SUCCESS = "success"
    TIP_OVERLOAD = "tip overload"
    ARM_CONTACT = "arm contact"
    HULL_CONTACT = "hull contact"


def judge(hull_impulse: float, hull_peak: float, link_impulse: float, tip_peak: float,
          tip_limit: float = np.inf) -> tuple[Outcome, str]:
    """Verdict and reason from the summed contact-impulse magnitudes [N s] of the hull and of the arm
    links other than the tip, the peak normal forces [N] of the hull and of the tip, and the force the
    tip may take [N] (worst first: hull, other links, tip overload)."""
    if hull_impulse > 0.0:
        return Outcome.HULL_CONTACT, f"the hull touched with {hull_impulse:.3f} N s of impulse, peak {hull_peak:.0f} N"
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


@dataclass(frozen=True)
class Latency:
    """A computation delay (module docstring)."""

    seconds: float | None  # the same for every step; None: each step's own wall-clock time ("measured")
    modes: frozenset[Mode] = frozenset(Mode)  # the modes whose steps are delayed (the braking baseline: always)


def parse_latency(spec: str) -> Latency:
    """The computation delay from its spec: "none" (0 s), "measured", or a number of seconds >= 0,
    optionally followed by "@" and the comma-separated modes whose steps it delays (default: all)."""
    allowed = f"allowed: none, {MEASURED}, or a number of seconds >= 0, optionally @MODES such as @II,III"
    delay, at, modes = spec.partition("@")
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
    return Latency(value, chosen)


SEARCH_ITERATIONS = 20  # the certificate's line-search screen in "switching-search"
CONTACT_MARGIN = 0.02  # m: Modes II and III's body clearance in "switching-contact-margin" (default 5 mm)
SOFT_TIP_WEIGHT = 4.0  # s/m: J_II's weight on the tip's speed at contact in "switching-soft-tip" (default 2)
SCREEN_MARGIN = 0.015  # m: the clearance F's plans keep in "switching-screens" (Mode I's 2 cm less 5 mm)
CERTIFICATE_MARGIN = 0.04  # m: the clearance F's plans keep in "switching-warm-margin" (default: Mode I's 2 cm)
LOOSE_QP_TOL = 1e-4  # HPIPM's residual tolerances for Mode I's QPs in "switching-loose-qp" (default 1e-6)
SOLVE_BUDGET = 0.07  # s: IPOPT's wall-clock limit on Modes II and III in "switching-realtime" (not reproducible)


def paper(s: SwitchingSettings) -> SwitchingSettings:
    """Mode II and its hand-over to Mode III as the paper has them: 0.1 s intervals (dt in [0.05,
    0.1] s), bodies 5 mm off the plane at contact as before it, and Mode III entered after the N_p =
    1 step wherever the tip is."""
    return replace(s, contact_tolerance=None, mode2=replace(s.mode2, dt_nominal=0.1, dt_bounds=(0.05, 0.1),
                                                            terminal_margin=None))


def budgeted(s: SwitchingSettings) -> SwitchingSettings:
    """Modes II and III's IPOPT stopped after SOLVE_BUDGET of wall-clock time; its iterate is used
    when it satisfies the constraints, else the mode's fallback (controller.switching)."""
    budget = {"max_wall_time": SOLVE_BUDGET}
    return replace(s, mode2=replace(s.mode2, ipopt_options={**s.mode2.ipopt_options, **budget}),
                   mode3=replace(s.mode3, ipopt_options={**s.mode3.ipopt_options, **budget}))


# The controllers by name: how each changes the given SwitchingSettings ("braking" does not use them).
# "switching-sharp" is the default as it was until 2026-12-01: the support function smoothed at 1e-7 m
# (SHARP), no deploy deadline, HPIPM's own mu0 (100). The variants after it are the A/B cases of issue
# 4's note, measured then: they run on SHARP, without the deadline (unless they ask for it) and with
# mu0 = 100, without `redeploy` and with the paper's J_III, as when they were measured (up to the
# last digits: the SQP's elimination was rewritten after, and J_III got its clearance parameters);
# all but "switching-sharp" build on the paper's Mode II hand-over (`paper`) unless they say otherwise
# (bench/results/switch_variants, handover_*, mode2_cap100 and the others).
SHARP = ModelOptions(support_smoothing=DELTA)


def _robust_mu0(s: SwitchingSettings) -> SwitchingSettings:
    """Mode I's QPs with HPIPM's own initial barrier parameter (ROBUST's 100), the default until the
    second session of 2026-12-01."""
    return replace(s, mode1=replace(s.mode1, sqp=replace(s.mode1.sqp, qp_mu0=None)))


def _approach_only(s: SwitchingSettings) -> SwitchingSettings:
    """J_III as the paper has it (the hull's approach speed alone): no clearance term, the default
    until the third session of 2026-12-01 (same compiled code, so equal only to the solvers' last
    digits to the runs measured before it)."""
    return replace(s, mode3=replace(s.mode3, clearance_weight=0.0))


def _mode3_1s(s: SwitchingSettings) -> SwitchingSettings:
    """Mode III over 10 intervals (1 s), the default until the fourth session of 2026-12-01
    (controller.mode3; bench/results/mode3_horizon)."""
    return replace(s, mode3=replace(s.mode3, horizon=10))


def _before_pitch_bound_and_stop(variant: Callable[[SwitchingSettings], SwitchingSettings]
                  ) -> Callable[[SwitchingSettings], SwitchingSettings]:
    """The variant as it was before the fifth session of 2026-12-01 (every variant measured before
    it): the certificate's minimum-violation IPOPT run to its end, not stopped at its first proof
    of F (`certificate_stop`), from the braking rollout, also when the deploy deadline switches either
    way (`deadline_first`), and Mode I's OCPs without their pitch bound (`pitch_limit`)."""
    return lambda s: variant(replace(s, certificate_stop=Stop.NONE, certificate_plan_start=False, deadline_first=False,
                                     mode1=replace(s.mode1, pitch_limit=None)))


def _before_witness(variant: Callable[[SwitchingSettings], SwitchingSettings]
                    ) -> Callable[[SwitchingSettings], SwitchingSettings]:
    """The variant as it was measured in the fifth session of 2026-12-01: the certificate's
    minimum-violation IPOPT started from the braking rollout and stopped at its first iterate with
    slacks within the tolerance (Stop.SLACK), not at its first RK4 witness from Mode I's plan, and
    solved even when the deploy deadline switches either way (`deadline_first`)."""
    return lambda s: variant(replace(s, certificate_stop=Stop.SLACK, certificate_plan_start=False,
                                     deadline_first=False))


def _as_measured(variant: Callable[[SwitchingSettings], SwitchingSettings], s: SwitchingSettings
                 ) -> SwitchingSettings:
    return variant(_approach_only(_robust_mu0(_mode3_1s(replace(s, deploy_deadline=False, redeploy=False)))))


_MEASURED_ON_SHARP: dict[str, Callable[[SwitchingSettings], SwitchingSettings]] = {
    "switching-sharp": lambda s: s,
    "switching-sharp-deadline": lambda s: replace(s, deploy_deadline=True),  # the deadline alone (no smoothing)
    "switching-paper": paper,
    "switching-paper-fine2": lambda s: replace(paper(s), mode2=replace(s.mode2, terminal_margin=None)),
    "switching-paper-strut-check": lambda s: replace(s, mode2=replace(s.mode2, dt_nominal=0.1,
                                                                      dt_bounds=(0.05, 0.1))),
    "switching-search": lambda s: replace(paper(s), certificate_search=SEARCH_ITERATIONS),
    "switching-searching": lambda s: replace(s, certificate_search=SEARCH_ITERATIONS),  # on today's hand-over
    "switching-certified-release": lambda s: replace(s, certified_release=True),
    "switching-certified-release-at-rest": lambda s: replace(s, certified_release=True, separation_speed=0.0),
    "switching-screens": lambda s: replace(s, minimum_violation=False, certificate_margin=SCREEN_MARGIN,
                                           certified_release=True),  # the screens decide both ways
    "switching-background": lambda s: replace(s, background_certificate=True),
    "switching-realtime": lambda s: budgeted(replace(s, background_certificate=True)),
    "switching-screens-realtime": lambda s: budgeted(_MEASURED_ON_SHARP["switching-screens"](s)),
    "switching-speed-abs": lambda s: replace(s, mode1=replace(s.mode1, sqp=replace(s.mode1.sqp,
                                                                              qp_mode=QPMode.SPEED_ABS))),
    "switching-soft-tip": lambda s: replace(s, mode2=replace(s.mode2, ee_speed_weight=SOFT_TIP_WEIGHT)),
    "switching-warm": lambda s: replace(paper(s), certificate_warm_start=True),
    "switching-warm-margin": lambda s: replace(paper(s), certificate_warm_start=True,
                                               certificate_margin=CERTIFICATE_MARGIN),
    "switching-deadline": lambda s: replace(paper(s), deploy_deadline=True),
    "switching-search-deadline": lambda s: replace(paper(s), certificate_search=SEARCH_ITERATIONS,
                                                   deploy_deadline=True),
    "switching-contact-margin": lambda s: replace(paper(s), mode2=replace(paper(s).mode2,
                                                                          distance_margin=CONTACT_MARGIN),
                                                  mode3=replace(s.mode3, distance_margin=CONTACT_MARGIN)),
}
_MEASURED_BEFORE_PITCH_BOUND: dict[str, Callable[[SwitchingSettings], SwitchingSettings]] = {
    "switching-no-stop": lambda s: s,  # the default before the fifth session of 2026-12-01
    "switching-mode3-1s": _mode3_1s,  # the default before the fourth session of 2026-12-01
    "switching-certificate-cap100": lambda s: replace(s, certificate_max_iter=100),  # bench/results/certificate_cap
    # measured with Mode III over 1 s, so with it:
    # J_III's clearance term (controller.mode3; bench/results/hull_clearance):
    "switching-approach-only": lambda s: _approach_only(_mode3_1s(s)),  # the paper's J_III: no clearance term
    "switching-clearance-10cm": lambda s: _mode3_1s(replace(s, mode3=replace(s.mode3, hull_clearance=0.1))),
    "switching-clearance-weak": lambda s: _mode3_1s(replace(s, mode3=replace(s.mode3, hull_clearance=0.1,
                                                                              clearance_weight=0.3))),
    "switching-soft-contact": lambda s: _mode3_1s(replace(s, mode2=replace(s.mode2, contact_speed=0.2))),
    "switching-certified-release-now": lambda s: _mode3_1s(replace(s, certified_release=True)),
    # measured before Mode III's failed entry went back to Mode II (`redeploy`), so without it
    # (and without J_III's clearance term):
    "switching-no-redeploy": lambda s: _approach_only(_mode3_1s(replace(s, redeploy=False))),  # results/qp_mu0
    "switching-no-deadline": partial(_as_measured, lambda s: s),  # F alone
    "switching-retry": lambda s: _approach_only(_mode3_1s(replace(s, certificate_retry=True, redeploy=False))),
    "switching-loose-qp": lambda s: _approach_only(_mode3_1s(replace(s, redeploy=False, mode1=replace(
        s.mode1, sqp=replace(s.mode1.sqp, qp_tol=LOOSE_QP_TOL))))),
    **{name: partial(_as_measured, f) for name, f in _MEASURED_ON_SHARP.items()},
}
CONTROLLERS: dict[str, Callable[[SwitchingSettings], SwitchingSettings]] = {
    "switching": lambda s: s,
    "mode1-only": lambda s: replace(s, switching=False),
    "braking": lambda s: s,
    # the minimum-violation problem on a second thread, each step waiting up to 50 ms for the job it starts:
    "switching-background-50ms": lambda s: replace(s, background_certificate=True, certificate_wait=0.05),
    # Mode I's real-time iteration: one SQP iteration per period instead of two (bench/results/rti):
    "switching-rti": lambda s: replace(s, mode1=replace(s.mode1, sqp=replace(s.mode1.sqp, max_iter=1))),
    # the default of the fifth session of 2026-12-01 (bench/results/pitch_stop, pitch_stop_thrusters):
    "switching-slack-stop": _before_witness(lambda s: s),
    # F asked to keep CERTIFICATE_MARGIN (4 cm) instead of Mode I's 2 cm (bench/results/certificate_margin):
    "switching-certificate-margin": _before_witness(lambda s: replace(s, certificate_margin=CERTIFICATE_MARGIN)),
    **{name: _before_pitch_bound_and_stop(f) for name, f in _MEASURED_BEFORE_PITCH_BOUND.items()},
}
# The model each controller plans on, when it is not ModelOptions() (the default).
MODEL_OPTIONS: dict[str, ModelOptions] = {name: SHARP for name in _MEASURED_ON_SHARP}


def certificate_row(c: Certificate | None) -> dict | None:
    """A step's feasibility certificate for summary.json: the verdict, its evidence, the minimum
    violation [m] (null: IPOPT failed, which counts as F empty, or the screens alone decided) and
    the time [s]."""
    if c is None:
        return None
    return {"verdict": c.verdict.value, "method": c.method.value,
            "violation": c.violation if np.isfinite(c.violation) else None, "seconds": c.solve_time, "age": c.age}


def switches(reasons: Sequence[SwitchReason | None]) -> str:
    """"n (k by solver failure)" from the steps' switch reasons (None: no switch): the switches from
    Mode I to Mode II, and how many of them came from an IPOPT failure on the certificate's
    minimum-violation problem."""
    made = [r for r in reasons if r is not None]
    return f"{len(made)} ({made.count(SwitchReason.SOLVER_FAILURE)} by solver failure)"


def run(sc: Scenario, out: Path | None = None, video: Path | None = None, record: Path | None = None,
        plots: Path | None = None,
        settings: SwitchingSettings | None = None, controller: str = "switching",
        mismatch: str = mismatches.DEFAULT, seed: int = 0, latency: str = "none") -> dict:
    """Run one scenario; returns the summary (also written to out/summary.json when out is given).
    The plant's parameters differ from the controller's by `mismatch` drawn with `seed`
    (validation.mismatch; "" for none). `latency`: the computation delay (parse_latency; the
    module's docstring).

    `controller`: "switching" (ours), "mode1-only" (the same NMPC without switching: Mode I, with its
    braking fallback when a solve fails), "braking" (maximum thruster braking with attitude hold,
    the arm held at its posture: controller.rollouts.BrakingPolicy), or a variant of ours by its
    name in CONTROLLERS (each a change of SwitchingSettings, documented where the setting is)."""
    if controller not in CONTROLLERS:
        raise ValueError(f"unknown controller {controller!r}; allowed: {', '.join(CONTROLLERS)}")
    settings = CONTROLLERS[controller](settings or SwitchingSettings())
    latency_spec = parse_latency(latency)
    fixed_delay = latency_spec.seconds
    for path in (out, video.parent if video else None, record.parent if record else None, plots):
        if path is not None:
            try:
                path.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                raise ValueError(f"output path {path}: {e.strerror}; allowed: a writable folder") from None
    params, scene, plant, drawn = build_plant(sc, mismatch, seed)
    model = UVMSModel(params, scene.water, MODEL_OPTIONS.get(controller, ModelOptions()))
    h0, ref = initial_state(params, sc)
    plant.reset(h0)
    ctl = SwitchingNMPC(model, scene.planes, reference(params, sc), settings)
    braking = BrakingPolicy(model)
    ts = plant.model.opt.timestep
    recorder = None
    if video is not None:
        from uvms_mj.render import VideoRecorder
        recorder = VideoRecorder(plant, video, fps=VIDEO_FPS)
    recording = None
    if record is not None:
        from validation.recording import RunRecording
        recording = RunRecording(record, plant, model, f"{sc.name}-{controller}-{seed}")
    wall = next(i for i, p in enumerate(scene.planes) if p.name == "wall")
    hull_geoms = [i for i, g in enumerate(plant.geom_names) if g.startswith(HULL)]
    min_dist = np.full((len(plant.geom_names), len(scene.planes)), np.inf)
    hull_impulse, link_impulse, hull_peak, ee_peak, steps, failed = 0.0, 0.0, 0.0, 0.0, [], ()
    telemetry: dict[str, list] = {k: [] for k in ("t", "u", "h", "hull_distance", "link_distance", "tip_distance",
                                                  "tip_force")}
    tip = plant.geom_names.index(TIP_GEOM) if TIP_GEOM in plant.geom_names else None
    link_geoms = [i for i in range(len(plant.geom_names)) if i not in hull_geoms and i != tip]
    next_frame, wall_clock, u_prev, chunk = 0.0, time.perf_counter(), None, settings.mode1.dt
    paced_from = None  # wall-clock time [s] of simulated t = 0 (measured latency: when the first plan is ready)
    try:
        while plant.t < sc.duration - 1e-9:
            t = plant.t
            if sc.known_dead(t) != failed:  # the controller is told of dead thrusters when they fail
                failed = sc.known_dead(t)
                ctl.set_failed_thrusters(failed)
                braking.limit_thrust(ctl.lo, ctl.hi)
            ctl.current = scene.current.at(t)
            if controller == "braking":
                h = plant.state()
                u, dt = braking(h, h0[6:6 + params.n_joints], ctl.current), settings.mode1.dt
                info = None
            else:
                if fixed_delay is None and paced_from is not None:  # measured: no faster than real time
                    time.sleep(max(0.0, t - (time.perf_counter() - paced_from)))
                u, info = ctl.step(plant.state(), t)
                paced_from = time.perf_counter() if paced_from is None else paced_from
                dt = max(ts, round(info.dt / ts) * ts)
            computed = info.solve_time if info is not None else 0.0
            undelayed = u_prev is None or (info is not None and info.mode not in latency_spec.modes)
            delay = 0.0 if undelayed else round((computed if fixed_delay is None else fixed_delay) / ts) * ts
            segments = [(u_prev, delay), (u, dt - delay)] if delay > 0 else [(u, dt)]
            pieces = [(u_seg, piece) for u_seg, duration in segments for piece in _pieces(duration, ts, chunk)]
            for u_seg, duration in pieces:
                t_seg = plant.t
                report = plant.step(u_seg, duration)
                if recording is not None:
                    recording.log(plant.t, report, info, u_seg)
                min_dist = np.minimum(min_dist, report.distances)
                telemetry["t"].append(t_seg)
                telemetry["u"].append(report.u_applied)
                telemetry["h"].append(report.h)
                telemetry["hull_distance"].append(float(report.distances[hull_geoms, wall].min()))
                telemetry["link_distance"].append(float(report.distances[link_geoms, wall].min())
                                                  if link_geoms else np.nan)
                telemetry["tip_distance"].append(float(report.distances[tip, wall]) if tip is not None else np.nan)
                telemetry["tip_force"].append(max((c.peak_normal_force for c in report.contacts
                                                   if c.geom == TIP_GEOM), default=0.0))
                for c in report.contacts:
                    if c.body == HULL:
                        hull_impulse += float(np.linalg.norm(c.impulse))
                        hull_peak = max(hull_peak, c.peak_normal_force)
                    elif c.geom == TIP_GEOM:
                        ee_peak = max(ee_peak, c.peak_normal_force)
                    else:
                        link_impulse += float(np.linalg.norm(c.impulse))
                while recorder is not None and next_frame <= plant.t + 1e-9:
                    recorder.capture()
                    next_frame += 1.0 / VIDEO_FPS
            u_prev, period = u, max(dt, delay)
            steps.append({"t": t, "dt": period, "delay": delay, "mode": info.mode.value, "status": info.status.value,
                          "fallback": info.fallback.value, "solve_time": info.solve_time, "ocp_time": info.ocp_time,
                          "iterations": info.iterations, "horizon": info.horizon,
                          "certificate": certificate_row(info.certificate),
                          "switch": info.switch.value if info.switch else None} if info else
                         {"t": t, "dt": period, "delay": delay, "mode": "braking", "status": "-",
                          "fallback": Fallback.NONE.value, "solve_time": 0.0, "ocp_time": 0.0, "iterations": 0,
                          "horizon": 0, "certificate": None, "switch": None})
    finally:
        if recorder is not None:
            recorder.close()
        if recording is not None:
            recording.close()
    h = plant.state()
    n = params.n_joints
    task_error = float(np.linalg.norm(h[:3] - ref[:3]))
    modes = [s["mode"] for s in steps]
    timeline = [[s["t"], s["mode"]] for k, s in enumerate(steps) if k == 0 or modes[k - 1] != s["mode"]]
    per_mode = {}
    for m in [*(m.value for m in Mode), "braking"]:
        times = [s["solve_time"] for s in steps if s["mode"] == m]
        if times:
            per_mode[m] = {"steps": len(times), "median_s": float(np.median(times)),
                                 "p95_s": float(np.percentile(times, 95)), "max_s": float(np.max(times))}
    thrust = max_thrust_along(params, -scene.planes[wall].normal)
    outcome, reason = judge(hull_impulse, hull_peak, link_impulse, ee_peak, params.arm.tip_force_limit)
    summary = {
        "scenario": {"name": sc.name, **sc.to_data()}, "controller": controller,
        "mismatch": {"spec": mismatch, "seed": seed, "values": drawn}, "latency": latency,
        "verdict": outcome.value, "reason": reason,
        "modes": [m for k, m in enumerate(modes) if k == 0 or modes[k - 1] != m], "timeline": timeline,
        "min_distance": {g: {p.name: float(min_dist[i, j]) for j, p in enumerate(scene.planes)}
                         for i, g in enumerate(plant.geom_names)},
        "min_hull_distance": float(min_dist[hull_geoms].min()) if hull_geoms else None,
        "hull_contact_impulse": hull_impulse, "hull_peak_contact_force": hull_peak,
        "ee_peak_contact_force": ee_peak, "link_contact_impulse": link_impulse,
        "max_total_thrust_along_wall_normal": thrust,
        "final_task_error": task_error, "final_joint_angles": h[6:6 + n].tolist(),
        "solve_time": per_mode, "fallbacks": sum(s["fallback"] != Fallback.NONE.value for s in steps),
        "switches": switches([SwitchReason(s["switch"]) if s["switch"] else None for s in steps]),
        "simulated_s": plant.t, "wall_clock_s": time.perf_counter() - wall_clock, "steps": steps,
    }
    if out is not None:
        (out / "summary.json").write_text(json.dumps(summary, indent=1))
    if plots is not None:
        from validation import plots as figures
        names = {"thrusters": [th.name for th in params.thrusters], "joints": [lk.name for lk in params.arm.links]}
        figures.write({k: np.asarray(v) for k, v in telemetry.items()}, modes, names, plots)
    return summary
