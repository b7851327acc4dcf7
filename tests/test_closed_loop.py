"""The MuJoCo closed loop: the switching NMPC against physics it does not know, the controller
protocol and presets, the scenario registry and the `uvms` command line."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from controller.feasibility import Verdict
from controller.switching import Fallback, SwitchReason
from uvms import load_params, load_scene
from validation.cli import main
from validation.closed_loop import Outcome, judge, run
from validation.mismatch import DEFAULT, NONE, WIDE, draw, parse, resolve
from validation.scenarios import SCENARIOS, get
from validation.summary import Summary


def test_scenarios_are_listed_one_line_each(capsys) -> None:
    assert main(["scenarios"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [ln.split()[0] for ln in lines] == list(SCENARIOS)


@pytest.mark.parametrize("argv", [["run", "no-such-scenario"], ["run", "avoid-wall", "--set", "initial.gap"],
                                  ["run", "avoid-wall", "--set", "initial.sped=1"],
                                  ["run", "avoid-wall", "--set", "initial.gap=fast"],
                                  ["run", "avoid-wall", "--set", "initial.posture=sideways"],
                                  ["run", "avoid-wall", "--out", "/proc/forbidden/out"],
                                  ["run", "avoid-wall", "--latency", "fast"],
                                  ["campaign", "--latency", "-0.1", "--out", "/tmp/uvms-never-written"],
                                  ["run", "avoid-wall", "--latency", "0.1@IV"],
                                  ["run", "avoid-wall", "--latency", "0.1@"],
                                  ["run", "avoid-wall", "--strict"],
                                  ["run", "avoid-wall", "--latency", "measured", "--strict"],
                                  ["campaign", "--latency", "0:strict", "--out", "/tmp/uvms-never-written"],
                                  ["run", "avoid-wall", "--controller", "no-such-preset"],
                                  ["run", "avoid-wall", "--controller", "no_such_module:Class"],
                                  ["run", "avoid-wall", "--ctl", "mode3.horizn=10"],
                                  ["run", "avoid-wall", "--ctl", "mode3.horizon=ten"],
                                  ["run", "avoid-wall", "--controller", "braking", "--ctl", "redeploy=false"],
                                  ["campaign", "--controllers", "switching,nope", "--out", "/tmp/uvms-never-written"]])
def test_bad_input_is_one_line_naming_what_is_allowed(argv, capsys) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("uvms: error:") and "allowed" in err and "\n" not in err


@pytest.mark.slow
def test_a_delay_for_some_modes_delays_only_their_steps(tmp_path) -> None:
    """latency "0.03@I" on the demo's approach (wall-headon, seed 0): the steps computed in Mode I get
    the 0.03 s delay, those of Modes II and III none, as the spec says. Both kinds occur in the
    first 0.6 s on any machine: at 1.2 m/s with its horizontal thrusters lost the hull would reach
    the wall 0.4 m ahead within about 0.35 s, so Mode II must begin before then. A delayed step is
    two physics pieces (the previous input, then its own), and the plots' mode bands still follow
    the steps: each band starts where a step of that mode starts (the summary's timeline).
    (That a delayed step holds the previous input is the next test's.)"""
    from validation.observers import Telemetry
    from validation.plots import mode_bands

    seen: list[Telemetry] = []

    def telemetry(plant) -> Telemetry:
        seen.append(Telemetry(plant))
        return seen[-1]

    sc = replace(get("wall-headon"), duration=0.6)
    s = run(sc, latency="0.03@I", out=tmp_path, observers=[telemetry])
    later = s.steps[1:]
    assert {st.mode for st in later} >= {"I", "II"}
    for st in later:
        assert st.delay == pytest.approx(0.03 if st.mode == "I" else 0.0), st
    data = seen[0].arrays()
    assert len(data["t"]) > len(s.steps)  # delayed steps are split in two pieces
    bands = mode_bands(data["t"], data["mode"], s.simulated_s)
    assert [mode for _, _, mode in bands] == [mode for _, mode in s.timeline]
    assert [start for start, _, _ in bands] == pytest.approx([t for t, _ in s.timeline])


def test_a_computation_delay_holds_the_previous_input(tmp_path, monkeypatch) -> None:
    """latency 0.05 s with the braking controller (0.1 s periods) on wall-headon: every input the
    plant receives is logged (Plant.step), and the oracle is the braking policy itself, evaluated
    on the plant's own state at each sample time. The first period gets u_0 throughout (the run
    starts with the first plan ready); in every later period k the plant gets u_k-1 for the first
    0.05 s and u_k (computed from the state at t_k) for the rest. Exact equality: the same
    function of the same state, and the plant clips nothing here (within the input bounds)."""
    from controller.model import UVMSModel
    from controller.rollouts import BrakingPolicy
    from uvms_mj.plant import Plant

    calls, step = [], Plant.step

    def logged(self, u, duration):
        calls.append((self.t, self.state(), np.array(u, float), duration))
        return step(self, u, duration)

    monkeypatch.setattr(Plant, "step", logged)
    sc = get("wall-headon").with_overrides({"duration": "0.5", "faults": "none", "current.velocity": "0,0,0"})
    s = run(sc, controller="braking", mismatch=NONE, latency="0.05", out=tmp_path)
    assert s.latency == "0.05" and [st.t for st in s.steps] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
    params = load_params()
    braking = BrakingPolicy(UVMSModel(params, load_scene().water))
    h0 = calls[0][1]
    samples = [c for c in calls if any(abs(c[0] - st.t) < 1e-9 for st in s.steps)]
    commanded = [braking(c[1], h0[6:6 + params.n_joints], np.zeros(3)) for c in samples]
    assert [round(c[3], 6) for c in calls] == [0.1] + [0.05] * 8
    np.testing.assert_array_equal(calls[0][2], commanded[0])
    for k in range(1, 5):
        first, second = calls[2 * k - 1], calls[2 * k]
        assert first[0] == pytest.approx(0.1 * k) and second[0] == pytest.approx(0.1 * k + 0.05)
        np.testing.assert_array_equal(first[2], commanded[k - 1])
        np.testing.assert_array_equal(second[2], commanded[k])


class _Sensing:
    """Zero input with a 0.1 s period; records what its wrist sensor reads (the protocol's sense)."""

    def reset(self, task) -> None:
        self.n, self.read = task.params.n_inputs, []

    def sense(self, wrench: np.ndarray) -> None:
        self.read.append(np.array(wrench, float))

    def step(self, h, t):
        from controller.protocol import StepInfo
        return np.zeros(self.n), StepInfo(t=t, dt=0.1, mode="zero")


@pytest.mark.parametrize("latency", ["none", "0.05"])
def test_the_wrist_sensor_reads_each_periods_mean_contact_force(latency, monkeypatch) -> None:
    """arm-deployed with no input: the tip meets the wall 0.05 s in. Before each step but the first
    the loop hands the controller the period's mean contact wrench on the arm's last link; its force
    times the period equals the impulse the plant reported per contact (PlantReport.contacts) on the
    last link's geoms over the plant steps of that period, which a delay splits in two. To 1e-9 N s
    (the same forces summed in another order)."""
    from uvms_mj.build import TIP_GEOM
    from uvms_mj.plant import Plant

    reports, step = [], Plant.step

    def logged(self, u, duration):
        r = step(self, u, duration)
        reports.append((self.t, r))
        return r

    monkeypatch.setattr(Plant, "step", logged)
    sc = get("arm-deployed").with_overrides({"duration": "0.6"})
    controller = _Sensing()
    s = run(sc, controller=controller, mismatch=NONE, latency=latency)
    last = {TIP_GEOM, f"{load_params().arm.links[-1].name}_geom"}
    assert len(controller.read) == len(s.steps) - 1 == 5
    for k, read in enumerate(controller.read, start=1):
        impulse = sum((c.impulse for t, r in reports if 0.1 * (k - 1) + 1e-9 < t <= 0.1 * k + 1e-9
                       for c in r.contacts if c.geom in last), np.zeros(3))
        np.testing.assert_allclose(read[:3] * 0.1, impulse, rtol=0, atol=1e-9)
    assert np.linalg.norm(controller.read[0][:3]) > 1.0  # the impact is read


class _Planner:
    """Returns at step k the plan P_k (three rows, each entry 0.01 (10 k + row) N or N m, within every
    bound), its first row as the input, with a 0.1 s period; its step advances the loop's clock by
    `slow_by` seconds at the steps in `slow` and by `fast_by` otherwise."""

    def __init__(self, clock: list[float], slow: set[int], split: bool = False, slow_by: float = 0.08,
                 fast_by: float = 0.001):
        self.clock, self.slow, self.k, self.told, self.split = clock, slow, 0, [], split
        self.slow_by, self.fast_by, self.began = slow_by, fast_by, []

    def late(self, u) -> None:
        self.told.append((self.k - 1, np.array(u, float)))

    def reset(self, task) -> None:
        self.n = task.params.n_inputs

    def plan(self, k: int) -> np.ndarray:
        return np.array([np.full(self.n, 0.01 * (10 * k + row)) for row in range(3)])

    def step(self, h, t):
        from controller.protocol import StepInfo
        self.began.append(self.clock[0])
        self.clock[0] += self.slow_by if self.k in self.slow else self.fast_by
        plan, self.k = self.plan(self.k), self.k + 1
        if self.split:  # the last row committed past the plan's end
            return plan[0], StepInfo(t=t, dt=0.1, mode="plan", u_pred=plan[:2], commit_after=plan[2:])
        return plan[0], StepInfo(t=t, dt=0.1, mode="plan", u_pred=plan)


def _fake_clock(monkeypatch) -> tuple[list[float], list[tuple[float, np.ndarray]]]:
    """The loop's clock made a fake one (advanced by the controller, and by the loop's waits), and
    every input the plant receives logged with its time (Plant.step)."""
    import validation.closed_loop as loop
    from uvms_mj.plant import Plant

    clock, calls, step = [0.0], [], Plant.step

    def logged(self, u, duration):
        calls.append((round(self.t, 6), np.array(u, float)))
        return step(self, u, duration)

    monkeypatch.setattr(Plant, "step", logged)
    monkeypatch.setattr(loop.time, "perf_counter", lambda: clock[0])
    monkeypatch.setattr(loop.time, "sleep", lambda seconds: clock.__setitem__(0, clock[0] + seconds))
    return clock, calls


@pytest.mark.parametrize("split", [False, True])
@pytest.mark.parametrize("strict", [True, False])
def test_strict_real_time_applies_the_inputs_committed_in_advance(strict, split, monkeypatch) -> None:
    """latency 0.05 s; steps 2, 3 and 4 take 0.08 s on the loop's clock (a fake one, advanced by the
    controller: the test does not depend on this machine's speed). Strict: each overrun's answer
    is discarded and the plant gets, after the delay, the next row of the last accepted plan (P_1),
    then its last row again once the plan is used up; step 5 is on time and its own plan's first
    row applies. Not strict: every answer applies, late or not. The oracle is the plans themselves
    (every input the plant receives is logged, Plant.step); the summary counts the three overruns,
    in the step records and in the mode's timing. The controller is told (`late`) after each
    discarded answer exactly the input the plant then received in its place, and only then. Strict,
    the loop waits (time.sleep, advancing the fake clock) until each step's sample time after the
    first step's end; not strict, it does not wait. With `split` each plan's last row comes as
    StepInfo.commit_after, not in u_pred: the same inputs."""
    clock, calls = _fake_clock(monkeypatch)
    ctl = _Planner(clock, slow={2, 3, 4}, split=split)
    sc = get("wall-headon").with_overrides({"duration": "0.6", "faults": "none", "current.velocity": "0,0,0"})
    s = run(sc, controller=ctl, mismatch=NONE, latency="0.05:strict" if strict else "0.05")
    P = ctl.plan
    late = [(P(1)[0], P(1)[1]), (P(1)[1], P(1)[2]), (P(1)[2], P(1)[2])] if strict else \
        [(P(1)[0], P(2)[0]), (P(2)[0], P(3)[0]), (P(3)[0], P(4)[0])]
    expected = [(0.0, P(0)[0]), (0.1, P(0)[0]), (0.15, P(1)[0])]
    for k, (during_delay, after) in zip((2, 3, 4), late, strict=True):
        expected += [(0.1 * k, during_delay), (0.1 * k + 0.05, after)]
    expected += [(0.5, late[-1][1]), (0.55, P(5)[0])]
    assert [t for t, _ in calls] == pytest.approx([t for t, _ in expected])
    for (t, got), (_, want) in zip(calls, expected, strict=True):
        np.testing.assert_array_equal(got, want, err_msg=f"input at t = {t}")
    assert [st.overrun for st in s.steps] == [False, False, True, True, True, False]
    assert s.overruns == 3 and s.solve_time["plan"].overruns == 3
    assert [st.fallback != "none" for st in s.steps] == [False, False, strict, strict, strict, False]
    assert [k for k, _ in ctl.told] == ([2, 3, 4] if strict else [])
    costs = [0.08 if k in {2, 3, 4} else 0.001 for k in range(len(s.steps))]
    unpaced = np.cumsum([0.0, *costs[:-1]])  # each step right after the one before
    paced = [0.0] + [costs[0] + st.t for st in s.steps[1:]]  # step k at t_k after the first step's end
    assert ctl.began == pytest.approx(paced if strict else unpaced)
    for (k, told), (_, applied) in zip(ctl.told, late, strict=False):
        np.testing.assert_array_equal(told, applied, err_msg=f"told after step {k}")


@pytest.mark.parametrize("split", [False, True])
def test_a_measured_delay_plays_the_committed_rows_once_an_inputs_period_has_run_out(split, monkeypatch) -> None:
    """latency "measured": each step's delay is its computation time on the loop's clock (a fake one,
    advanced by the controller: 0.03 s a step, 0.23 s at step 2; periods 0.1 s). The first input
    acts for its period from the start; each later one from its arrival for one period, then the
    rows its step committed, one period each, the last held. So step 1's delay plays P_0's second
    row (P_0[0]'s period ended at 0.1 s), step 2's delay P_1[0] for the 0.03 s left of its period,
    then P_1[1] and P_1[2] for 0.1 s each; P_2[0], arriving at 0.43 s when step 3 samples, acts
    over step 3's delay. The oracle is the plans themselves (every input the plant receives is
    logged, Plant.step); with `split` the last row comes as StepInfo.commit_after: the same inputs."""
    clock, calls = _fake_clock(monkeypatch)
    ctl = _Planner(clock, slow={2}, split=split, slow_by=0.23, fast_by=0.03)
    sc = get("wall-headon").with_overrides({"duration": "0.6", "faults": "none", "current.velocity": "0,0,0"})
    s = run(sc, controller=ctl, mismatch=NONE, latency="measured")
    P = ctl.plan
    expected = [(0.0, P(0)[0]), (0.1, P(0)[1]), (0.13, P(1)[0]), (0.2, P(1)[0]), (0.23, P(1)[1]), (0.33, P(1)[2]),
                (0.43, P(2)[0]), (0.46, P(3)[0]), (0.53, P(3)[0]), (0.56, P(4)[0])]
    assert [t for t, _ in calls] == pytest.approx([t for t, _ in expected])
    for (t, got), (_, want) in zip(calls, expected, strict=True):
        np.testing.assert_array_equal(got, want, err_msg=f"input at t = {t}")
    assert [st.delay for st in s.steps] == pytest.approx([0.0, 0.03, 0.23, 0.03, 0.03])
    assert s.overruns == 0 and not ctl.told


def test_overrides_parse_numbers_and_tuples() -> None:
    sc = get("wall-headon").with_overrides({"initial.velocity": "0.5,0,0", "current.velocity": "0.1,0,0",
                                            "faults.0.thrusters": "0,1"})
    assert sc.initial.velocity == (0.5, 0.0, 0.0) and sc.current.velocities == ((0.1, 0.0, 0.0),)
    assert sc.faults[0].thrusters == (0, 1)


def test_same_scenario_gives_the_same_summary(tmp_path) -> None:
    """Deterministic on one machine: the plant is deterministic and the controller has no
    randomness; wall-clock figures aside, two runs in one process agree exactly (across machines
    the solvers' last bits may differ, so this is a same-machine comparison)."""
    sc = replace(get("avoid-wall"), duration=0.4)
    a, b = (run(sc, out=tmp_path / k) for k in "ab")
    assert a.without_timings() == b.without_timings()


@pytest.mark.slow
def test_avoid_wall_never_leaves_mode_one_and_never_touches(tmp_path) -> None:
    """0.3 m/s towards the wall 1 m ahead with every thruster working: the braking rollout alone
    keeps the margin (a closed rollout, no solver), so Mode I throughout, and nothing comes within
    0.5 m of a plane (MuJoCo's distances)."""
    s = run(replace(get("avoid-wall"), duration=1.5), out=tmp_path)
    assert s.modes == ["I"]
    assert s.hull_contact_impulse == 0.0 and s.ee_peak_contact_force == 0.0
    assert min(d for g in s.min_distance.values() for d in g.values()) > 0.5


@pytest.mark.slow
def test_wall_headon_switches_and_the_arm_protects_the_hull(tmp_path) -> None:
    """The demo's run (wall-headon in MuJoCo: horizontal thrusters lost, a 0.25 m/s current pushing
    towards the wall, the default parameter mismatch drawn with seed 0), its first 2.5 s: the run
    starts in Mode I and goes through Mode II into Mode III (unavoidable: the hull would reach the
    wall 0.4 m ahead within about 0.35 s), the hull never touches (zero contact impulse, MuJoCo's
    contacts), the tip does touch, within the jaws' limit (params.arm.tip_force_limit). The exact
    mode sequence is not asked: it hangs on the solvers' last digits. The switch to Mode II is the
    step whose certificate found F empty (or IPOPT failed on it), or whose braking rollout left Mode
    II no more time (the deploy deadline). A headless video is written (EGL)."""
    video = tmp_path / "run.mp4"
    s = run(replace(get("wall-headon"), duration=2.5), out=tmp_path, video=video, mismatch=DEFAULT, seed=0)
    assert s.modes[0] == "I" and "II" in s.modes and "III" in s.modes[s.modes.index("II"):]
    assert s.hull_contact_impulse == 0.0
    assert 0.0 < s.ee_peak_contact_force <= load_params().arm.tip_force_limit
    assert video.stat().st_size > 10_000
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["verdict"] == s.verdict and np.isfinite(s.final_task_error)
    first = next(k for k, step in enumerate(summary["steps"]) if step["mode"] == "II")
    cert = summary["steps"][first]["certificate"]
    assert all(step["certificate"]["verdict"] == Verdict.FEASIBLE.value for step in summary["steps"][:first])
    expected = (SwitchReason.DEPLOY_DEADLINE if cert["verdict"] in (Verdict.FEASIBLE.value, Verdict.UNDECIDED.value)
                else SwitchReason.SOLVER_FAILURE if cert["violation"] is None else SwitchReason.F_EMPTY)
    assert summary["steps"][first]["switch"] == expected.value
    # every switch is a Mode II step; a step may also leave Mode I right after Mode II handed back
    # (the tip short of the wall, the hull moving away): then the timeline shows no I in between
    switched = [step for step in summary["steps"] if step["switch"] is not None]
    assert all(step["mode"] == "II" for step in switched) and int(s.switches.split()[0]) == len(switched)
    entries = sum(a == "I" and b == "II" for a, b in zip(s.modes, s.modes[1:], strict=False))
    assert entries <= len(switched)


def test_verdict_ranks_hull_then_links_then_a_tip_over_its_force_limit() -> None:
    """Bookkeeping, not physics: the verdict names the worst thing that happened. A tip that takes
    more than the jaws' rating (the parameter file's tip_force_limit, 200 N) is a failure even when
    nothing else touched; exactly at the limit it is not (Mode III may plan up to it)."""
    limit = load_params().arm.tip_force_limit
    assert judge(0.0, 0.0, 0.0, limit, limit)[0] is Outcome.SUCCESS
    assert judge(0.0, 0.0, 0.0, 0.0, limit)[0] is Outcome.SUCCESS
    over = judge(0.0, 0.0, 0.0, limit + 1.0, limit)
    assert over[0] is Outcome.TIP_OVERLOAD and f"{limit:.0f} N" in over[1]
    assert judge(0.0, 0.0, 0.5, limit + 1.0, limit)[0] is Outcome.ARM_CONTACT
    assert judge(0.1, 50.0, 0.5, limit + 1.0, limit)[0] is Outcome.HULL_CONTACT


def test_verdict_names_the_plane_the_hull_touched() -> None:
    """A hull 30 % heavier than its parameters (mass*1.3: about 38 N heavy in water), level and at
    rest with its lowest point 5 cm above the seafloor and 0.6 m off the wall, no input, in
    thrusters-dead's current (0.25 m/s onto the wall): MuJoCo sinks it onto the seafloor within 1 s.
    The tally must name the seafloor alone, as MuJoCo's own distances say: the hull's smallest
    distance below zero to the seafloor and above 0.3 m to the wall (it drifts less than 0.3 m in
    that time)."""
    from validation.observers import ContactTally
    from validation.setup import build_plant, initial_state

    sc = get("thrusters-dead")
    params, scene, plant, _ = build_plant(sc, "mass*1.3", 0)
    h0, _ = initial_state(params, sc)
    floor = next(p for p in scene.planes if p.name == "seafloor")
    h0[2] = -floor.offset + params.hull.size[2] / 2 + 0.05
    plant.reset(h0)
    tally, u = ContactTally(plant), np.zeros(params.n_inputs)
    for k in range(10):
        tally.observe(0.1 * k, plant.step(u, 0.1), None, u)
    c = tally.totals()
    hull = plant.geom_names.index("hull_geom")
    planes = [p.name for p in plant.scene.planes]
    assert c.min_distance[hull, planes.index("seafloor")] < 0.0 < 0.3 < c.min_distance[hull, planes.index("wall")]
    assert c.hull_planes == ("seafloor",)
    outcome, reason = judge(c.hull_impulse, c.hull_peak, c.link_impulse, c.tip_peak, hull_planes=c.hull_planes)
    assert outcome is Outcome.HULL_CONTACT and reason.startswith("the hull touched the seafloor with")


@pytest.mark.slow
def test_mode1_only_crashes_in_wall_headon(tmp_path) -> None:
    """The baseline of the same case (Mode I alone, no switching) cannot stop in time: within 1.2 s
    something other than the end-effector tip hits the wall (the hull, or the stowed arm's links
    that stick out in front of it), per MuJoCo's contacts."""
    s = run(replace(get("wall-headon"), duration=1.2), controller="mode1-only", mismatch=NONE)
    assert s.verdict in (Outcome.ARM_CONTACT.value, Outcome.HULL_CONTACT.value)
    assert s.hull_contact_impulse + s.link_contact_impulse > 1.0  # N s: a crash, not a graze


def test_a_crashing_run_is_recorded_and_the_others_finish(tmp_path) -> None:
    """A campaign of two runs, one of them broken (an arm posture that does not exist): the broken
    one is a row with verdict "error" and a one-line reason; the other finishes; both are in the CSV
    and markdown tables."""
    from validation.campaign import campaign

    good = replace(get("avoid-wall"), duration=0.3)
    bad = replace(good, name="broken", initial=replace(good.initial, posture="sideways"))
    rows = campaign([good, bad], ["braking"], workers=2, out=tmp_path)
    by_name = {r["scenario"]: r for r in rows}
    assert by_name["avoid-wall"]["verdict"] == "success"
    assert by_name["broken"]["verdict"] == "error" and "posture" in by_name["broken"]["reason"]
    assert (tmp_path / "results.csv").read_text().count("\n") == 3
    assert "broken" in (tmp_path / "results.md").read_text()


def test_mismatch_is_parsed_seeded_and_rejected_in_one_line() -> None:
    """The default spec parses; the same seed draws the same values, another seed others, all
    within their uniform ranges; bad specs give one line naming what is allowed."""
    assert {t.name for t in parse(DEFAULT)} == {"added_mass", "drag", "mass", "cob", "friction", "trim"}
    a, b, c = draw(DEFAULT, 3), draw(DEFAULT, 3), draw(DEFAULT, 4)
    assert a == b and a != c
    assert 0.8 <= a["added_mass"] <= 1.2 and -0.003 <= a["cob"] <= 0.003 and -2.0 <= a["trim"] <= 2.0
    for bad in ("added_mass*U(0.8)", "mass+U(0,1)", "viscosity*2", "drag*fast", "wider"):
        with pytest.raises(ValueError, match="allowed") as err:
            resolve(bad)
        assert "\n" not in str(err.value)


def test_run_takes_a_mismatch_by_name() -> None:
    """`run(mismatch="default")` draws the plant of the spec DEFAULT itself: the same seeded values,
    the same closed loop to the bit (oracle: the run given the spec), and the summary records the
    spec, not the name."""
    sc = replace(get("wall-headon"), duration=0.3)
    named, spelled = (run(sc, controller="braking", mismatch=m, seed=3) for m in ("default", DEFAULT))
    assert named.mismatch == spelled.mismatch and named.mismatch["spec"] == DEFAULT
    assert named.final_joint_angles == spelled.final_joint_angles
    assert named.min_hull_distance == spelled.min_hull_distance


def test_wide_mismatch_draws_within_its_declared_ranges() -> None:
    """The named "wide" spec: over 200 seeds every draw lies in its declared range (mass 0.8-1.3,
    added mass and drag 0.7-1.3, friction coefficient 0.1-0.8, current -0.2 to 0.2 m/s, trim error
    -2 to 2 N), and the draws
    span most of each range (a uniform draw's extremes over 200 seeds come within 2 % of its ends with
    probability above 1 - 2 * 0.98^200 = 0.96; 10 % is asked)."""
    assert resolve("wide") == WIDE and resolve("default") == DEFAULT and resolve("none") == NONE
    draws = [draw(WIDE, seed) for seed in range(200)]
    for name, (lo, hi) in {"mass": (0.8, 1.3), "added_mass": (0.7, 1.3), "drag": (0.7, 1.3),
                           "friction_coefficient": (0.1, 0.8), "current": (-0.2, 0.2), "trim": (-2.0, 2.0)}.items():
        values = np.array([d[name] for d in draws])
        assert lo <= values.min() and values.max() <= hi, name
        assert values.min() < lo + 0.1 * (hi - lo) and values.max() > hi - 0.1 * (hi - lo), name


def test_mismatch_changes_only_the_plant(params, scene) -> None:
    """apply() scales exactly the named plant fields (closed form) and leaves the controller's
    parameters (the input) untouched."""
    from validation.mismatch import apply

    plant, plant_scene, current, dead = apply(params, scene, {"added_mass": 1.5, "mass": 1.1, "cob": 0.002,
                                                             "friction": 0.5, "current": 0.1, "thruster": 3.7})
    np.testing.assert_allclose(plant.hull.added_mass, 1.5 * params.hull.added_mass)
    assert plant.hull.mass == pytest.approx(1.1 * params.hull.mass)
    assert plant.hull.cob[2] == pytest.approx(params.hull.cob[2] + 0.002)
    assert plant_scene.planes[0].friction == pytest.approx(0.5 * scene.planes[0].friction)
    assert current.tolist() == [0.1, 0.0, 0.0] and dead == [3]
    assert plant.arm.links[0].added_mass_coefficient == pytest.approx(1.5 * params.arm.links[0].added_mass_coefficient)
    assert load_params().hull.mass == params.hull.mass
    _, absolute, _, _ = apply(params, scene, {"friction_coefficient": 0.15})
    assert [p.friction for p in absolute.planes] == [0.15] * len(scene.planes)



@pytest.mark.parametrize("k", [0.8, 1.25])
def test_mass_split_into_weight_and_inertia_in_the_plant(params, scene, k: float) -> None:
    """`mass_weight` gives MuJoCo's plant the weight in water of `mass` (net vertical force at rest:
    gravity minus buoyancy from MuJoCo's own mass and gravity compensation, within 1e-9 N) with the
    nominal hull's inertia; `mass_inertia` gives the inertia of `mass` (the hull body's mass and
    inertia in MuJoCo's model, 1e-12 relative) with the nominal weight in water."""
    from uvms_mj.build import COB_MASS, HULL
    from uvms_mj.plant import Plant
    from validation.mismatch import apply

    def hull(values: dict) -> tuple[float, float, np.ndarray]:
        plant_params, plant_scene, _, _ = apply(params, scene, values)
        m = Plant(plant_params, plant_scene).model
        b = m.body(HULL).id
        cob = [c for c in range(m.nbody) if m.body_parentid[c] == b and m.body_mass[c] == COB_MASS]
        in_water = sum(float(m.body_mass[c]) * (1.0 - float(m.body_gravcomp[c])) for c in [b, *cob])
        assert len(cob) == 1
        return in_water * float(-m.opt.gravity[2]), float(m.body_mass[b]), m.body_inertia[b].copy()

    nominal, heavy, weight, inertia = hull({}), hull({"mass": k}), hull({"mass_weight": k}), hull({"mass_inertia": k})
    assert weight[0] == pytest.approx(heavy[0], abs=1e-9) and inertia[0] == pytest.approx(nominal[0], abs=1e-9)
    assert weight[0] != pytest.approx(nominal[0], abs=1.0)
    assert weight[1] == nominal[1] and inertia[1] == pytest.approx(heavy[1], rel=1e-12)
    np.testing.assert_allclose(inertia[2], heavy[2], rtol=1e-12)

def test_recording_verifies_and_reads_back(tmp_path) -> None:
    """`uvms run --record` writes an .rrd that `rerun rrd verify` accepts; read back with Rerun's own
    reader it holds MuJoCo's geometry, the controller's superellipsoids, the planes, force arrows,
    the predicted horizons, the mode, and one solve-time and one model-water sample per control step."""
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    import rerun.chunk as rc

    rrd = tmp_path / "run.rrd"
    s = run(replace(get("avoid-wall"), duration=0.5), out=tmp_path, record=rrd)
    rerun_cli = shutil.which("rerun", path=str(Path(sys.executable).parent)) or "rerun"
    ok = subprocess.run([rerun_cli, "rrd", "verify", str(rrd)], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    chunks = list(rc.RrdReader(rrd).store().stream())
    paths = {c.entity_path for c in chunks}
    for expected in ("/world/mujoco/hull_geom", "/world/mujoco/ee_tip", "/world/model/hull", "/world/planes/wall",
                     "/world/forces/thrusters", "/world/plan/hull", "/world/plan/tip", "/mode",
                     "/telemetry/distance/wall/hull_geom", "/telemetry/input/t1_front_starboard"):
        assert expected in paths, expected
    rows = sum(c.num_rows for c in chunks if c.entity_path == "/telemetry/solver/solve_time")
    assert rows == len(s.steps) == 5
    weights = [v for c in chunks if c.entity_path == "/telemetry/model/extra_weight"
               for v in c.to_record_batch().column("Scalars:scalars").to_pylist()]
    assert len(weights) == 5 and weights[0] == [0.0]  # the observer needs two states for an estimate
    assert any(w != [0.0] for w in weights[1:])  # the default preset observes (the draw's hull is not nominal)
    text = " ".join(str(v) for c in chunks if c.entity_path == "/run"
                    for v in c.to_record_batch().column("TextDocument:text").to_pylist())
    assert "Verdict: success" in text and '"mode3"' in text and "mismatch" in text


def test_plots_are_written(tmp_path) -> None:
    """--plots writes the control-input, state and contact figures as PNG files."""
    run(replace(get("avoid-wall"), duration=0.3), plots=tmp_path)
    for name in ("control_inputs.png", "states.png", "contact.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_mode_three_failed_entry_redeploys_instead_of_holding_the_arm_rigid(tmp_path, monkeypatch) -> None:
    """Mode III's solve made to fail (ModeIIIOCP.solve returns its input guess with status FAILED:
    a failure made certain, not left to the solvers' last digits), on wall-headon's first 1.5 s
    (default mismatch, seed 0, where Modes II and III come within the first 0.5 s): with `redeploy`
    (the default) every failed Mode III entry is Mode II afresh from the measured state
    (Fallback.REDEPLOY) and the rigid-arm fallback never runs; without it (the switching-paper
    preset's rule) the fallback is maximum braking with the arm held rigid (Fallback.HOLD).
    Oracle: the fallback rules of controller.switching, read off the steps."""
    from controller.mode3 import ModeIIIOCP, ModeIIISolution
    from controller.transcription import SolverStatus

    def failing(self, h0, guess, current=None, duals=None):
        hs, us, fs = self.unpack(guess)
        return ModeIIISolution(SolverStatus.FAILED, hs, us, fs, 0.0, 0, np.nan, np.asarray(guess),
                               np.zeros(0), np.zeros(0))

    monkeypatch.setattr(ModeIIIOCP, "solve", failing)
    out = {}
    for redeploy in (False, True):
        s = run(replace(get("wall-headon"), duration=1.5), ctl={"redeploy": redeploy}, mismatch=DEFAULT, seed=0,
                out=tmp_path / str(redeploy))
        out[redeploy] = {st.fallback for st in s.steps}
    assert Fallback.HOLD.value in out[False] and Fallback.REDEPLOY.value not in out[False]
    assert Fallback.REDEPLOY.value in out[True] and Fallback.HOLD.value not in out[True]


def test_a_controller_of_ones_own_runs_in_run_and_campaign(tmp_path) -> None:
    """The example PD station keeper (examples/pd_station_keeper.py, a class speaking
    controller.protocol) runs through `uvms run --controller examples.pd_station_keeper:PDStationKeeper`
    and in a two-run campaign, with no change to the testbed. Oracle: avoid-wall with every thruster
    working and no mismatch, 1 s: the keeper brakes the 0.3 m/s approach (MuJoCo's distances: nothing
    within 0.5 m of the wall) and its label is the mode of every step."""
    from validation.campaign import campaign

    name = "examples.pd_station_keeper:PDStationKeeper"
    assert main(["run", "avoid-wall", "--set", "duration=1.0", "--controller", name, "--mismatch", "none",
                 "--out", str(tmp_path / "run")]) == 0
    s = Summary.read(tmp_path / "run" / "summary.json")
    assert s.controller == name and s.modes == ["pd"] and s.verdict == "success"
    assert min(s.min_distance["hull_geom"].values()) > 0.5
    rows = campaign([replace(get("avoid-wall"), duration=0.3)], [name, "braking"], workers=2, out=tmp_path / "c",
                    mismatch=NONE)
    assert [r["verdict"] for r in rows] == ["success", "success"]


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["switching", "mode1-only", "braking", "switching-paper", "switching-rti"])
def test_every_preset_steps_on_every_scenario(preset, tmp_path) -> None:
    """Each kept preset runs 0.3 s of every scenario (so that none can rot unseen): it steps, its
    inputs are finite (the plant would raise on a non-finite one), and the summary has a verdict."""
    for name in SCENARIOS:
        s = run(replace(get(name), duration=0.3), controller=preset, seed=0)
        assert s.steps and 0.3 <= s.simulated_s + 1e-9 < 0.4 and s.verdict in {o.value for o in Outcome}


class _Listener:
    """A controller that only keeps what it is told and holds every input at zero."""

    def reset(self, task) -> None:
        self.task = task

    def step(self, h, t):
        from controller.protocol import StepInfo

        return np.zeros(self.task.params.n_inputs), StepInfo(t=t, dt=0.1)


@pytest.mark.parametrize("spec", ["mass*1.25 trim+1.5", "mass*0.85 trim+-2", "mass_inertia*1.3"])
def test_the_controller_is_told_the_trim_checks_weight_with_its_declared_error(params, scene, spec: str) -> None:
    """The task's trim is the drawn vehicle's weight in water at the start (the closed form of the
    plant's masses and volumes, MuJoCo's own measurement checked in test_plant_hydrostatics) plus the
    mismatch's declared trim error: told less the model's own it is (k - 1) m g + error for `mass*k`,
    the error alone for `mass_inertia` (1e-9 N: the same numbers); the run's summary records it."""
    listener = _Listener()
    summary = run(replace(get("wall-headon"), duration=0.1), controller=listener, mismatch=spec)
    assert summary.mismatch["told_trim"] == listener.task.trim
    drawn, rho, g = draw(spec, 0), scene.water.density, scene.water.gravity
    k = drawn.get("mass", 1.0)
    expected = (k - 1.0) * params.hull.mass * g + drawn.get("trim", 0.0)
    assert listener.task.trim - params.weight_in_water(rho, g) == pytest.approx(expected, abs=1e-9)


class _Garbage:
    """A controller that returns a non-finite input (the loop must refuse it, not pass it on)."""

    def reset(self, task) -> None:
        self.n = task.params.n_inputs

    def step(self, h, t):
        from controller.protocol import StepInfo

        return np.full(self.n, np.nan), StepInfo(t=t, dt=0.1)


def test_a_controller_returning_garbage_is_stopped_in_one_line() -> None:
    """A controller's non-finite input stops the run with one line naming the controller and what
    is allowed, before the plant receives it."""
    with pytest.raises(ValueError, match="allowed") as err:
        run(replace(get("avoid-wall"), duration=0.2), controller=_Garbage(), mismatch=NONE)
    assert "_Garbage" in str(err.value) and "\n" not in str(err.value)


def test_a_scene_without_a_plane_named_wall_runs() -> None:
    """The worked yawed-wall example with its wall renamed: the loop reports the scene's first plane
    in place of "wall" (the distances it records are that plane's; MuJoCo's distance at the start
    equals the scenario's 1 m gap of the hull front, its closed form)."""
    sc = get("wall-yawed-cross-current").with_overrides({"scene.planes.0.name": "slope", "initial.plane": "slope",
                                                         "task.plane": "slope", "duration": "0.2"})
    s = run(sc, controller="mode1-only", mismatch=NONE)
    assert s.verdict == "success" and "slope" in s.min_distance["hull_geom"]
    assert 0.9 < s.min_distance["hull_geom"]["slope"] <= 1.0 + 1e-6
