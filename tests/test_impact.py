"""The tip's impact law (controller.impact) against the MuJoCo plant's measured peak force."""

from __future__ import annotations

import numpy as np
import pytest

from controller import impact
from controller.model import UVMSModel
from uvms import load_params
from uvms_mj.build import TIP_GEOM
from uvms_mj.plant import Plant


@pytest.mark.parametrize("arm", ["alpha3", "alpha4", "alpha6"])
def test_contact_parameters_are_the_plants(arm, scene) -> None:
    """The parameter file's contact is the plant's: every obstacle's solref time constant and
    solimp d_max are the arm's, and `contact_weight` is the translational body_invweight0 that MuJoCo
    computes for the last link at compile time (to 1e-6 relative: the file rounds to 7 digits)."""
    params = load_params(arm=arm)
    m = Plant(params, scene).model
    for p in scene.planes:
        g = m.geom(f"plane_{p.name}").id
        assert m.geom_solref[g, 0] == params.arm.contact_time_constant and m.geom_solref[g, 1] == 1.0
        assert m.geom_solimp[g, 1] == params.arm.contact_impedance
    tip_body = m.geom_bodyid[m.geom(TIP_GEOM).id]
    assert m.body_invweight0[tip_body, 0] == pytest.approx(params.arm.contact_weight, rel=1e-6)


def _mujoco_impact(plant: Plant, model: UVMSModel, h: np.ndarray, plane) -> tuple[float, np.ndarray, bool]:
    """The plant's peak tip normal force [N] of the hull and arm coasting (no input) into the plane
    from h, the state one physics step before the tip first touches, and whether only the tip touched."""
    plant.reset(h)
    u, before, first, peak, only_tip = np.zeros(model.n_inputs), plant.state(), None, 0.0, True
    for _ in range(500):
        rep = plant.step(u, plant.model.opt.timestep)
        tip = [c for c in rep.contacts if c.geom == TIP_GEOM]
        only_tip &= all(c.geom == TIP_GEOM for c in rep.contacts)
        if tip:
            first = before if first is None else first
            peak = max(peak, *(c.peak_normal_force for c in tip))
        elif first is not None:
            break
        before = rep.h
    assert first is not None, "the tip never touched"
    return peak, first, only_tip


STRUT = [(0.0, 0.0, 0.0, 0.0), (0.0, 0.3, 0.0, 0.0)]  # the arm along the normal: the case Mode II plans
FOLDED = [(0.0, 0.3, 0.6, 0.0), (0.0, 0.6, 0.3, 0.0), (0.5, 0.3, 0.3, 0.0)]


@pytest.mark.parametrize("posture", STRUT + FOLDED)
def test_impact_law_bounds_the_plants_peak_force(params, scene, posture) -> None:
    """The hull and arm coast (no thrust, no torque) into the wall at 0.2 and 0.5 m/s, the tip 2 mm
    off; MuJoCo's contact is the oracle. The law's force from the state one physics step before
    touch bounds MuJoCo's peak to within the spring term the first step adds: the contact is found
    up to v dt deep, and k r / (b v) = dt / (2 d_max tau) = 5.3 % (dt 2 ms, tau 20 ms); 7 % is
    allowed. For the arm along the normal (sticking and sliding alike) the law is tight: MuJoCo's
    peak is at least 85 % of it. For folded postures it may be conservative (a sliding tip meets
    less inertia than a sticking one) but not by more than 2.5 times."""
    model = UVMSModel(params, scene.water)
    wall = next(p for p in scene.planes if p.name == "wall")
    plant = Plant(params, scene)
    n = params.n_joints
    for speed in (0.2, 0.5):
        h = np.zeros(model.n_states)
        h[2], h[6:6 + n], h[6 + n] = -1.5, posture, speed
        gap = float(wall.signed_distance(np.asarray(model.ee_pose(h)[0]).ravel())) - params.arm.tip_radius
        h[:3] -= (gap - 0.002) * wall.normal
        measured, first, only_tip = _mujoco_impact(plant, model, h, wall)
        predicted = impact.peak_force(model, first, wall)
        assert only_tip
        assert measured <= 1.07 * predicted, (speed, measured, predicted)
        assert measured >= (0.85 if posture in STRUT else 0.4) * predicted, (speed, measured, predicted)
