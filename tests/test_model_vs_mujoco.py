"""The paper's model against MuJoCo's own dynamics (the plant with its fluid off): open-loop
trajectories and the contact-wrench mapping."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from controller.model import UVMSModel
from uvms.conventions import euler_zyx_to_matrix
from uvms_mj.build import EE_SITE
from uvms_mj.plant import Plant, PlantSettings
from validation.model_gap import RIGID_MODEL, RIGID_PLANT, open_loop_gap


@pytest.mark.slow
@pytest.mark.parametrize("arm", ["alpha3", "alpha4", "alpha6"])
def test_open_loop_trajectories_agree_without_fluid(scene, arm) -> None:
    """Rigid body, gravity and buoyancy on both sides (no fluid, added mass, joint friction or
    limits), the same thrust and free arm for 2 s: the model (RK4, 2.5 ms) and MuJoCo agree to
    below 1 mm and 0.05 deg, and the gap halves when MuJoCo's timestep halves (0.5 -> 0.25 ms;
    ratio 2 +- 10%): what remains is the first-order error of MuJoCo's implicitfast integrator,
    not a difference of dynamics."""
    from uvms import load_params

    p = load_params(arm=arm)
    gaps = [open_loop_gap(p, scene, (2.0,), RIGID_MODEL, dataclasses.replace(RIGID_PLANT, timestep=ts))[0]
            for ts in (0.0005, 0.00025)]
    assert gaps[1].position < 1e-3 and gaps[1].attitude < 0.05
    assert gaps[0].position / gaps[1].position == pytest.approx(2.0, rel=0.1)


def test_contact_wrench_maps_like_mj_applyFT(params, scene) -> None:
    """A wrench F^w in a random obstacle frame R_w at the end-effector (paper eq. F_contact):
    the model's generalized force equals MuJoCo's mj_applyFT of the world wrench at the EE site
    on the last link, mapped to the paper's speeds (qfrc_paper = T^T qfrc_mujoco, T =
    blockdiag(R, I)), to 1e-10."""
    model = UVMSModel(params, scene.water)
    plant = Plant(params, scene.with_planes(()), PlantSettings(build=RIGID_PLANT))
    m, d = plant.model, plant.data
    n, rng = params.n_joints, np.random.default_rng(4)
    for _ in range(20):
        h = np.zeros(params.n_states)
        h[:3], h[3:6] = rng.normal(size=3), rng.uniform(-1, 1, 3)
        h[6:6 + n] = params.arm.home + rng.uniform(-0.5, 0.5, n)
        plant.set_state(h)
        Rw = Rotation.random(random_state=rng).as_matrix()
        Fw = rng.normal(0, 10, 6)
        qfrc = np.zeros(m.nv)
        last = m.body(params.arm.links[-1].name).id
        mujoco.mj_applyFT(m, d, Rw @ Fw[:3], Rw @ Fw[3:], d.site_xpos[m.site(EE_SITE).id], last, qfrc)
        T = np.eye(m.nv)
        T[:3, :3] = euler_zyx_to_matrix(*h[3:6])
        out = model.generalized_forces(h, np.zeros(params.n_inputs), Fw, Rw, np.zeros(3), np.zeros(3))
        np.testing.assert_allclose(np.asarray(out[-1]).ravel(), T.T @ qfrc, atol=1e-10)
