"""Scenarios as data: the files under assets/scenarios, their validation, the dotted overrides, the
registry shared by the MuJoCo and the Kane-model closed loops, and a plane of any pose in the plant."""

from __future__ import annotations

import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from uvms import load_params
from uvms.conventions import euler_zyx_to_matrix
from uvms.params import ParamError
from validation.cli import main
from validation.scenarios import ALLOWED_KEYS, SCENARIO_DIR, SCENARIOS, get, load_scenario, parse
from validation.setup import build_plant, current_profile, initial_state, reference, scene_of

ALL = (0, 1, 2, 3, 4, 5, 6, 7)
STOWED = {7: 1.6, 8: 1.55}
HOME = {7: 0.3, 8: 0.6}
X_1 = 0.7715000000000001  # m: the hull front 1 m off the default wall
X_04 = 1.3715000000000002  # m: 0.4 m off it

# name: (h0, ref as {index: value} (the rest 0; alpha4: 20 states), current (times, velocities),
#        (thrusters the controller is told of, at [s]), duration [s])
FROZEN = {
    "avoid-wall": ({0: X_1, 2: -1.5, **STOWED, 10: 0.3}, {0: X_1, 2: -1.5, **STOWED},
                   ([0.0], [[0.0, 0.0, 0.0]]), ((), 0.0), 4.0),
    "wall-headon": ({0: X_04, 2: -1.5, **STOWED, 10: 1.2}, {0: X_1, 2: -1.5, **STOWED},
                    ([0.0], [[0.25, 0.0, 0.0]]), ((0, 1, 2, 3), 0.0), 5.0),
    "wall-oblique": ({0: X_04, 2: -1.5, **STOWED, 10: 1.0392304845413265, 11: 0.5999999999999999},
                     {0: X_1, 2: -1.5, **STOWED}, ([0.0], [[0.25, 0.0, 0.0]]), ((0, 1, 2, 3), 0.0), 5.0),
    "arm-deployed": ({0: X_04, 2: -1.5, **HOME, 10: 1.2}, {0: X_1, 2: -1.5, **HOME},
                     ([0.0], [[0.25, 0.0, 0.0]]), ((0, 1, 2, 3), 0.0), 5.0),
    "current-steady": ({0: X_04, 2: -1.5, **STOWED}, {0: X_04, 2: -1.5, **STOWED},
                       ([0.0], [[0.3, 0.0, 0.0]]), ((), 0.0), 4.0),
    "current-gust": ({0: X_04, 2: -1.5, **STOWED}, {0: X_04, 2: -1.5, **STOWED},
                     ([0.0, 1.0, 2.0], [[0.1, 0.0, 0.0], [0.1, 0.0, 0.0], [0.4, 0.0, 0.0]]), ((), 0.0), 4.0),
    "thrusters-dead": ({0: 1.1715, 2: -1.5, **STOWED, 10: 0.4}, {0: X_1, 2: -1.5, **STOWED},
                       ([0.0], [[0.25, 0.0, 0.0]]), (ALL, 0.0), 5.0),
    "corner": ({0: 1.2715, 2: -2.45, **STOWED, 10: 0.5, 12: -0.2}, {0: X_1, 2: -2.45, **STOWED},
               ([0.0], [[0.0, 0.0, 0.0]]), ((), 0.0), 3.0),
    "mission-near-wall": ({0: 1.4715, 2: -1.5, **STOWED}, {0: 1.4715, 2: -1.5, **STOWED},
                          ([0.0], [[0.15, 0.0, 0.0]]), (ALL, 1.0), 4.0),
    "kane-avoidable": ({0: X_1, **STOWED, 10: 0.3}, {0: X_1, **STOWED}, ([0.0], [[0.0, 0.0, 0.0]]), ((), 0.0), 3.0),
    "kane-thrusters-dead-current": ({0: 1.1715, **STOWED, 10: 0.3}, {0: X_1, **STOWED},
                                    ([0.0], [[0.15, 0.0, 0.0]]), (ALL, 0.0), 5.0),
    "kane-current": ({0: 1.4715, **STOWED, 10: 0.6}, {0: X_1, **STOWED}, ([0.0], [[0.3, 0.0, 0.0]]), ((), 0.0), 3.0),
    "kane-thrusters-dead": ({0: 1.3915000000000002, **STOWED, 10: 0.7}, {0: X_1, **STOWED},
                            ([0.0], [[0.0, 0.0, 0.0]]), (ALL, 0.0), 3.0),
}


def _state(entries: dict[int, float]) -> np.ndarray:
    h = np.zeros(20)
    for i, v in entries.items():
        h[i] = v
    return h


def _bits(a: np.ndarray) -> bytes:
    """The bytes of a float array, -0.0 as 0.0 (a signed zero changes no result here)."""
    return (np.asarray(a, float) + 0.0).tobytes()


@pytest.mark.parametrize("name", list(FROZEN))
def test_the_named_scenarios_keep_their_values_bit_for_bit(name: str) -> None:
    """The start state h0, the reference, the current profile, the faults (the plant's, with a
    mismatch's unknown dead thruster 6 added after the scenario's own; the controller's schedule),
    the duration and the arm of the nine MuJoCo scenarios and the four Kane-model ones, against
    literals. They are literals, not recomputed, because results have been recorded under these
    names: a change to a file, to the schema or to the state construction must show here as a
    changed number, not pass as a self-consistent round trip. Exact comparison (signed zeros
    aside): the same doubles give the same closed loop."""
    h0_want, ref_want, (times, velocities), (told, at), duration = FROZEN[name]
    sc = get(name)
    params = load_params(arm=sc.arm)
    h0, ref = initial_state(params, sc)
    assert sc.arm == "alpha4" and sc.duration == duration and len(h0) == 20
    assert _bits(h0) == _bits(_state(h0_want)) and _bits(ref) == _bits(_state(ref_want))
    current = current_profile(sc)
    assert _bits(current.times) == _bits(times) and _bits(current.velocities) == _bits(velocities)
    assert sc.known_dead(at) == told and (at == 0.0 or sc.known_dead(at - 1e-3) == ())
    _, scene, plant, _ = build_plant(sc, "thruster=6", 0)
    faults = [(f.thruster, f.start_time, f.mode.value, f.value) for f in plant.settings.faults]
    assert faults == [(i, at, "zero", 0.0) for i in told] + ([] if 6 in told else [(6, 0.0, "zero", 0.0)])
    assert [(p.name, p.normal.tolist(), p.offset) for p in scene.planes] == [("wall", [-1.0, 0.0, 0.0], 2.0),
                                                                            ("seafloor", [0.0, 0.0, 1.0], 3.0)]
    assert ("kane" in sc.tags) == name.startswith("kane-")


def test_the_kane_loop_reads_the_kane_files() -> None:
    from validation.kane_closed_loop import SCENARIOS as KANE

    assert sorted(KANE) == ["kane-avoidable", "kane-current", "kane-thrusters-dead", "kane-thrusters-dead-current"]
    assert all(KANE[n] == get(n) for n in KANE)


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_every_file_loads_and_writes_back_to_the_same_scenario(name: str) -> None:
    sc = SCENARIOS[name]
    assert parse(sc.to_data(), name, Path(sc.file)) == sc
    assert sc.description and sc.duration > 0


def test_the_listing_names_tags_and_description(capsys) -> None:
    assert main(["scenarios"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [ln.split()[0] for ln in lines] == sorted(p.stem for p in SCENARIO_DIR.glob("*.toml"))
    for ln, name in zip(lines, SCENARIOS, strict=True):
        sc = SCENARIOS[name]
        assert ",".join(sc.tags) in ln and ln.endswith(sc.description)


def _with(data: dict, path: str, value) -> dict:
    """A copy of a file's data with one dotted entry set (value None: removed)."""
    out = tomllib.loads((SCENARIO_DIR / "wall-headon.toml").read_text()) if data is None else data
    node = out
    *parents, last = path.split(".")
    for p in parents:
        node = node[int(p)] if p.isdigit() else node[p]
    if value is None:
        del node[last]
    else:
        node[last] = value
    return out


@pytest.mark.parametrize(("path", "value", "field"), [
    ("colour", "red", "colour"),
    ("duration", {"value": 5.0, "unit": "min"}, "duration"),
    ("duration", 5.0, "duration"),
    ("duration", {"value": -1.0, "unit": "s"}, "duration"),
    ("arm", "alpha9", "arm"),
    ("initial.posture", "sideways", "initial.posture"),
    ("initial.plane", "ceiling", "initial.plane"),
    ("initial.plane", "seafloor", "initial.plane"),
    ("initial.gap", None, "initial.gap"),
    ("initial.position", {"value": [0.0, 0.0, -1.0], "unit": "m"}, "initial.position"),
    ("initial.velocity", {"value": [1.0, 0.0], "unit": "m/s"}, "initial.velocity"),
    ("initial.joints", {"value": [0.0, 0.0, 0.0, 0.0], "unit": "rad"}, "initial.posture"),
    ("current.times", {"value": [0.0], "unit": "s"}, "current.velocity"),
    ("faults.0.thrusters", [0, 8], "faults[0].thrusters"),
    ("faults.0.mode", "stuck", "faults[0]"),
    ("faults.0.force", {"value": 10.0, "unit": "N"}, "faults[0].force"),
    ("task.kind", "waypoints", "task.kind"),
    ("task.speed", 1.0, "task.speed"),
])
def test_a_bad_field_is_one_line_naming_the_file_the_field_and_what_is_allowed(tmp_path, path, value, field) -> None:
    data = _with(None, path, value)
    file = tmp_path / "broken.toml"
    with pytest.raises(ParamError) as err:
        parse(data, "broken", file)
    msg = str(err.value)
    assert msg.startswith(f"broken.toml: {field}") and "\n" not in msg, msg
    assert "allowed: " in msg or msg.endswith("missing key"), msg


def test_a_broken_file_on_disk_is_one_line(tmp_path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("schema = [")
    with pytest.raises(ParamError, match=r"^bad\.toml: not valid TOML"):
        load_scenario(bad)
    with pytest.raises(ParamError, match="no such scenario file"):
        load_scenario(tmp_path / "absent.toml")


def test_overrides_are_applied_to_the_data_and_validated_like_a_file() -> None:
    """`--set` keys: each override lands where the file would have it (units from the schema), one
    form of an alternative replaces the other, and the result is checked like a file."""
    gust = get("current-gust")
    sc = gust.with_overrides({"current.velocity": "0.1,0.4,0", "initial.pitch": "15", "duration": "2"})
    assert sc.current.times == (0.0,) and sc.current.velocities == ((0.1, 0.4, 0.0),) and sc.duration == 2.0
    h0, _ = initial_state(load_params(), sc)
    assert h0[4] == np.radians(15.0) and h0[0] == X_04
    moved = gust.with_overrides({"initial.position": "0.5,0.2,-1", "faults.0.thrusters": "2", "faults.0.at": "1.5"})
    assert moved.initial.position == (0.5, 0.2, -1.0) and moved.initial.gap is None
    assert moved.faults[0].thrusters == (2,) and moved.known_dead(1.4) == () and moved.known_dead(1.5) == (2,)
    assert get("wall-headon").with_overrides({"faults": "none"}).faults == ()
    with pytest.raises(ParamError, match=r"^current-gust.toml: initial.posture: .*allowed: stowed, home$"):
        gust.with_overrides({"initial.posture": "sideways"})
    with pytest.raises(ParamError, match=r"^current-gust.toml: initial.joints: joint 0 at 9.0 rad is outside"):
        gust.with_overrides({"initial.joints": "9,0,0,0"})
    assert gust.with_overrides({"initial.joints": "0.1,0.2,0.3,0.4"}).initial.posture is None
    with pytest.raises(ParamError) as err:
        gust.with_overrides({"initial.speed": "1"})
    assert str(err.value).startswith("unknown setting 'initial.speed'; allowed: ")
    assert all(k in str(err.value) for k in ALLOWED_KEYS)
    for key, text in (("initial.gap", "near"), ("initial.velocity", "1,x,0"), ("faults.0.known", "maybe"),
                      ("current.velocities", "1,2")):
        with pytest.raises(ParamError, match=rf"^setting {key}=.* is malformed; allowed: "):
            gust.with_overrides({key: text})


def test_a_waypoint_task_is_a_reference_in_time() -> None:
    """Positions linear between the knots, held outside them; the start's attitude and posture, zero
    velocities (the controller takes it as a function of t)."""
    sc = get("avoid-wall").with_overrides({"task.kind": "waypoints", "task.times": "1,3",
                                           "task.positions": "0.5,0,-1.5;0.9,0.2,-1.3", "task.yaw": "10"})
    params = load_params()
    ref = reference(params, sc)
    assert callable(ref)
    np.testing.assert_allclose(ref(0.0)[:3], [0.5, 0.0, -1.5])
    np.testing.assert_allclose(ref(2.0)[:3], [0.7, 0.1, -1.4])
    np.testing.assert_allclose(ref(9.0)[:3], [0.9, 0.2, -1.3])
    h0, at_end = initial_state(params, sc)
    np.testing.assert_array_equal(at_end, ref(sc.duration))
    assert at_end[5] == np.radians(10.0) and np.all(at_end[6:10] == h0[6:10]) and np.all(at_end[10:] == 0.0)


def _ellipsoid_distance(plane, centre: np.ndarray, R: np.ndarray, semi: np.ndarray) -> float:
    """Signed distance [m] of an ellipsoid (centre, rotation, semi-axes) to a plane: its support
    function along -n is |diag(semi) R^T n|."""
    return float(plane.normal @ centre + plane.offset - np.linalg.norm(semi * (R.T @ plane.normal)))


def test_a_plane_of_any_pose_is_where_the_scene_puts_it() -> None:
    """The plant's own distance (mj_geomDistance) of the hull ellipsoid and of the tip sphere to
    planes of arbitrary normal equals the closed form from the state (the hull) or the body's
    position (the tip). First the worked example: the hull starts facing the 60 deg wall with its
    front 1 m off it, so the distance is the gap itself. Then a plane tilted off every axis with the
    vehicle rolled, pitched and yawed. Tolerance 1e-9 m: both are the same closed form in doubles
    (MuJoCo's plane-convex distance is the support point, not an iteration)."""
    from uvms_mj.build import TIP_GEOM
    from uvms_mj.plant import Plant

    yawed = get("wall-yawed-cross-current")
    params, scene, plant, _ = build_plant(yawed, "", 0)
    h0, _ = initial_state(params, yawed)
    plant.reset(h0)
    hull, tip = plant.geom_names.index("hull_geom"), plant.geom_names.index(TIP_GEOM)
    wall = [p.name for p in scene.planes].index("wall")
    assert scene.planes[wall].normal @ [np.cos(np.radians(60.0)), np.sin(np.radians(60.0)), 0.0] == \
        pytest.approx(-1.0, abs=1e-12)
    assert plant.signed_distances()[hull, wall] == pytest.approx(1.0, abs=1e-9)

    tilted = yawed.with_overrides({"scene.planes.0.normal": "-0.48,-0.6,0.64", "scene.planes.0.point": "1.5,1,-0.5",
                                   "initial.position": "0.2,-0.1,-1.2", "task.position": "0.2,-0.1,-1.2",
                                   "initial.roll": "10", "initial.pitch": "-20", "initial.yaw": "50"})
    scene = scene_of(tilted)
    plant = Plant(params, scene)
    h, _ = initial_state(params, tilted)
    plant.reset(h)
    semi = params.hull.size / 2
    R = euler_zyx_to_matrix(*h[3:6])
    got = plant.signed_distances()
    r_tip = float(plant.model.geom_size[plant.model.geom(name=TIP_GEOM).id][0])
    tip_centre = plant.data.geom_xpos[plant.model.geom(name=TIP_GEOM).id]
    for j, plane in enumerate(scene.planes):
        assert got[hull, j] == pytest.approx(_ellipsoid_distance(plane, h[:3], R, semi), abs=1e-9)
        assert got[tip, j] == pytest.approx(float(plane.normal @ tip_centre + plane.offset - r_tip), abs=1e-9)
    assert abs(scene.planes[0].normal[2]) > 0.5  # (tilted indeed)


@pytest.mark.slow
def test_the_yawed_wall_example_runs_with_mode_I(tmp_path) -> None:
    """The worked example, 0.5 s with the Mode-I-only controller and no mismatch: it runs, nothing
    touches (the wall is 1 m ahead at 0.3 m/s), and the summary's scenario is the file's data.
    (About 1 s with the compiled solvers cached; compiling the certificate's problem for these planes
    takes about 90 s on a cold cache, hence slow.)"""
    from validation.closed_loop import run
    from validation.mismatch import NONE

    sc = replace(get("wall-yawed-cross-current"), duration=0.5)
    s = run(sc, out=tmp_path, controller="mode1-only", mismatch=NONE)
    assert s.simulated_s == pytest.approx(0.5) and s.verdict == "success"
    assert 0.8 < s.min_distance["hull_geom"]["wall"] < 1.0
    assert parse({k: v for k, v in s.scenario.items() if k != "name"}, "again", Path("again.toml")) == \
        replace(sc, name="again")


def test_faults_reach_the_plant_and_the_controller_as_declared() -> None:
    """A stuck thruster the controller is not told of, beside the file's dead ones it is told of: the
    plant gets every fault (stuck at its force [N] from its time), the controller's schedule only
    the known dead ones; an angular rate in deg/s becomes rad/s in h0."""
    sc = get("wall-headon").with_overrides({"faults.1.thrusters": "5", "faults.1.mode": "stuck",
                                            "faults.1.force": "-12.5", "faults.1.at": "0.5",
                                            "initial.angular_velocity": "0,0,90"})
    assert sc.faults[1].known is False and sc.known_dead(0.0) == sc.known_dead(9.0) == (0, 1, 2, 3)
    params, _, plant, _ = build_plant(sc, "thruster=6", 0)
    faults = [(f.thruster, f.start_time, f.mode.value, f.value) for f in plant.settings.faults]
    assert faults == [(i, 0.0, "zero", 0.0) for i in range(4)] + [(5, 0.5, "stuck", -12.5), (6, 0.0, "zero", 0.0)]
    h0, _ = initial_state(params, sc)
    n = params.n_joints
    np.testing.assert_array_equal(h0[9 + n:12 + n], [0.0, 0.0, np.pi / 2])
