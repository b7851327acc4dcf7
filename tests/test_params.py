"""The parameter file: every variant loads; bad input stops with one clear line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from uvms.conventions import FRD_TO_FLU
from uvms.params import DEFAULT_VEHICLE, ParamError, arm_variants, load_params

TEXT = DEFAULT_VEHICLE.read_text()


@pytest.mark.parametrize(("arm", "n"), [("alpha3", 3), ("alpha4", 4), ("alpha6", 6)])
def test_arm_variants_load(arm: str, n: int) -> None:
    p = load_params(arm=arm)
    assert p.n_joints == n
    assert p.n_inputs == 8 + n
    assert p.n_states == 2 * (6 + n)
    lo, hi = p.input_bounds()
    assert np.all(lo < hi) and lo.shape == (8 + n,)


def test_default_arm_is_the_four_joint_one() -> None:
    assert load_params().arm.name == "alpha4"
    assert set(arm_variants()) == {"alpha3", "alpha4", "alpha6"}


def test_thrusters_make_the_hull_fully_actuated() -> None:
    """Eight thrusters span all six body wrench directions (paper: fully actuated AUV)."""
    B = load_params().allocation_matrix()
    assert B.shape == (6, 8)
    assert np.linalg.matrix_rank(B, tol=1e-6) == 6


def test_literature_centre_of_buoyancy_converted_from_frd() -> None:
    """von Benzon et al. give r_b = [0, 0, -0.01] m in FRD: 1 cm ABOVE the CoG, i.e. +z in FLU."""
    r_b_frd = np.array([0.0, 0.0, -0.01])
    np.testing.assert_allclose(load_params(trim=False).hull.cob, FRD_TO_FLU @ r_b_frd)


def test_trim_is_folded_into_one_rigid_body() -> None:
    """The trimmed hull's mass, CoM, volume and CoB are the sums and moments of its parts, and its
    inertia about the new CoM follows the parallel-axis theorem (closed form, point-mass trim)."""
    bare, trimmed = load_params(trim=False).hull, load_params().hull
    parts = [(bare.mass, bare.com, bare.volume, bare.cob)] + [
        (x.mass, x.position, x.volume, x.position) for x in trimmed.trim]
    m = sum(p[0] for p in parts)
    c = sum(p[0] * p[1] for p in parts) / m
    v = sum(p[2] for p in parts)
    b = sum(p[2] * p[3] for p in parts) / v
    assert trimmed.mass == pytest.approx(m) and trimmed.volume == pytest.approx(v)
    np.testing.assert_allclose(trimmed.com, c)
    np.testing.assert_allclose(trimmed.cob, b)
    # Inertia about the origin is additive; shifting to the CoM removes m |c|^2 terms.
    about_origin = bare.inertia + sum(
        (p[0] * (p[1] @ p[1] * np.eye(3) - np.outer(p[1], p[1])) for p in parts[1:]), np.zeros((3, 3)))
    np.testing.assert_allclose(trimmed.inertia + m * (c @ c * np.eye(3) - np.outer(c, c)), about_origin, atol=1e-12)
    assert len(load_params(trim=False).hull.trim) == 0


BAD = [
    # (description, old text, new text, expected fragments of the one-line error)
    ("negative mass", "mass = { value = 13.5,", "mass = { value = -13.5,", ["hull.mass", "allowed: > 0"]),
    ("negative link volume", "volume = { value = 1.885e-4,", "volume = { value = -1.885e-4,",
     ["links.shoulder.volume", "allowed: > 0"]),
    ("eps above 2", "exponents = { value = [0.4, 0.4]", "exponents = { value = [0.4, 2.5]",
     ["hull.superellipsoid.exponents", "allowed: <= 2"]),
    ("eps zero", "exponents = { value = [0.4, 0.4]", "exponents = { value = [0.0, 0.4]",
     ["hull.superellipsoid.exponents", "allowed: > 0"]),
    ("non-unit thruster direction", "direction = { value = [0.7071067811865476, 0.7071067811865476, 0.0]",
     "direction = { value = [0.8, 0.7071067811865476, 0.0]", ["thrusters[0].direction", "unit vector"]),
    ("missing key", 'volume = { value = 0.0134, unit = "m^3", source = "von Benzon et al. 2022, Table 1" }\n', "",
     ["hull.volume", "missing key"]),
    ("unknown key", "[hull]\n", '[hull]\ncolour = "yellow"\n', ["hull.colour", "unknown key", "allowed:"]),
    ("wrong shape", "inertia = { value = [0.26, 0.23, 0.37]", "inertia = { value = [0.26, 0.23]",
     ["hull.inertia", "shape (2,)", "allowed: (3,)"]),
    ("wrong unit", 'volume = { value = 0.0134, unit = "m^3"', 'volume = { value = 0.0134, unit = "l"',
     ["hull.volume", "allowed: 'm^3'"]),
    ("no source", 'source = "von Benzon et al. 2022, J. Mar. Sci. Eng. 10:1898, Table 1" }',
     'source = "" }', ["hull.mass", "source"]),
    ("home outside joint range", "home = { value = [0.0, 0.3, 0.6, 0.0]", "home = { value = [0.0, 3.0, 0.6, 0.0]",
     ["arms.alpha4.home", "outside its range"]),
    ("unknown link in arm", '"elbow", "wrist_roll"]', '"elbow", "wrist_rol"]', ["arms.alpha4.links", "'wrist_rol'"]),
    ("not TOML", "[hull]\n", "[hull\n", ["not valid TOML"]),
]


@pytest.mark.parametrize(("what", "old", "new", "fragments"), BAD, ids=[b[0] for b in BAD])
def test_bad_input_gives_one_clear_line(tmp_path: Path, what: str, old: str, new: str,
                                        fragments: list[str]) -> None:
    assert old in TEXT, f"test setup: {old!r} not in the parameter file"
    path = tmp_path / DEFAULT_VEHICLE.name
    path.write_text(TEXT.replace(old, new, 1))
    with pytest.raises(ParamError) as err:
        load_params(path)
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith(DEFAULT_VEHICLE.name), msg
    for frag in fragments:
        assert frag in msg, msg


def test_unknown_arm_lists_the_choices() -> None:
    with pytest.raises(ParamError, match="allowed: alpha4, alpha3, alpha6"):
        load_params(arm="alpha5")


def test_parameters_are_frozen(params) -> None:
    with pytest.raises(AttributeError):
        params.hull.mass = 1.0
    with pytest.raises(ValueError):
        params.hull.inertia[0] = 1.0


@pytest.mark.parametrize(("old", "new", "fragment"), [
    ('normal = { value = [-1.0, 0.0, 0.0]', 'normal = { value = [-1.0, 0.5, 0.0]', "planes[0].normal"),
    ('times = { value = [0.0], unit = "s"', 'times = { value = [0.0, 0.0], unit = "s"', "strictly increasing"),
    ('density = { value = 1000.0', 'density = { value = -1000.0', "water.density"),
])
def test_bad_scene_gives_one_clear_line(tmp_path: Path, old: str, new: str, fragment: str) -> None:
    from uvms.scene import DEFAULT_SCENE, load_scene

    text = DEFAULT_SCENE.read_text()
    assert old in text
    path = tmp_path / DEFAULT_SCENE.name
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(ParamError) as err:
        load_scene(path)
    assert "\n" not in str(err.value) and fragment in str(err.value), str(err.value)
