"""Architecture and packaging: import boundaries, the exported MJCF, the pinned dm-control pairing."""

from __future__ import annotations

import subprocess
import sys

import mujoco
import numpy as np
import pytest

from uvms_mj.export import MJCF_DIR, main


def _modules_after_import(module: str) -> set[str]:
    code = f"import sys, {module}; print(' '.join(sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return set(out.stdout.split())


@pytest.mark.parametrize(("module", "forbidden"), [
    ("uvms_mj.plant", "casadi"), ("uvms_mj.export", "casadi"), ("uvms_mj.demo", "casadi"),
    ("controller", "mujoco"), ("uvms", "mujoco"), ("uvms", "casadi"),
])
def test_import_boundaries(module: str, forbidden: str) -> None:
    """controller/ never imports mujoco; uvms_mj/ never imports casadi; the shared core neither."""
    assert forbidden not in _modules_after_import(module)


def test_exported_mjcf_is_up_to_date() -> None:
    """assets/mjcf is generated from the parameter file; regenerate with `make assets`."""
    assert main(["--check"]) == 0


def test_exported_mjcf_loads_in_mujoco_and_dm_control() -> None:
    """The default file opens in MuJoCo (the viewer's loader) and in dm_control.Physics (the
    pinned mujoco/dm-control pair works; mujoco 4.0.0 would fail here)."""
    from dm_control import mujoco as dm_mujoco

    path = MJCF_DIR / "bluerov2_heavy_alpha_alpha4_wall_and_seafloor.xml"
    model = mujoco.MjModel.from_xml_path(str(path))
    physics = dm_mujoco.Physics.from_xml_path(str(path))
    physics.reset(0)  # keyframe "home"
    physics.step()
    assert model.nkey == 1 and model.key("home").id == 0
    assert np.all(np.isfinite(physics.data.qpos))
    names = {model.body(i).name for i in range(model.nbody)}
    assert {"hull", "hull_cob", "base_yaw", "wrist_roll"} <= names
