"""The plant and a scenario as a dm-control `control.Environment` (a `dm_env` task): for
learned controllers or learned initial guesses, with the same physics and mismatch as the NMPC.

Observations: `state` (the paper's h, measured from MuJoCo) and `wall_distance` (every vehicle
geom's signed distance to every plane, m). Actions: thruster forces [N] and joint torques [N m]
within the parameter file's limits, held over `control_timestep` (0.1 s, the NMPC's dt_nom).
Reward in [0, 1] per step: dm_control's `tolerance` of the hull's distance to the task position
(1 within 5 cm, falling off over 1 m), and 0 for any step in which the hull touches an obstacle.
"""

from __future__ import annotations

import collections

import numpy as np
from dm_control import mujoco as dm_mujoco
from dm_control.mujoco import wrapper
from dm_control.rl import control
from dm_control.utils import rewards
from dm_env import specs

from uvms_mj.build import HULL
from uvms_mj.plant import Plant, PlantReport
from validation import mismatch as mismatches
from validation.closed_loop import build_plant, initial_state
from validation.scenarios import Scenario, get


class PlantPhysics(dm_mujoco.Physics):
    """dm_control's Physics over the testbed's Plant: the same MjData, stepped by Plant.step (so
    buoyancy, the added-mass iteration, faults, clipping and the instability checks all apply)."""

    plant: Plant
    last_report: PlantReport | None = None

    @classmethod
    def from_plant(cls, plant: Plant) -> PlantPhysics:
        physics = cls(wrapper.MjData(plant.data))
        physics.plant = plant
        return physics

    def step(self, nstep: int = 1) -> None:
        u = np.array(self.data.ctrl)
        self.last_report = self.plant.step(u, nstep * self.plant.model.opt.timestep)


class WallTask(control.Task):
    """A scenario's start, task and obstacles as a dm_control task."""

    def __init__(self, scenario: Scenario, params, h0: np.ndarray, ref: np.ndarray):
        super().__init__()
        self.scenario, self.params, self.h0, self.ref = scenario, params, h0, ref
        self._lo, self._hi = params.input_bounds()

    def initialize_episode(self, physics: PlantPhysics) -> None:
        physics.plant.reset(self.h0)
        physics.last_report = None

    def action_spec(self, physics: PlantPhysics) -> specs.BoundedArray:
        return specs.BoundedArray((self.params.n_inputs,), np.float64, self._lo, self._hi, name="u")

    def before_step(self, action: np.ndarray, physics: PlantPhysics) -> None:
        physics.data.ctrl[:] = action  # PlantPhysics.step hands it to Plant.step

    def get_observation(self, physics: PlantPhysics) -> collections.OrderedDict:
        return collections.OrderedDict(state=physics.plant.state(),
                                       wall_distance=physics.plant.signed_distances().ravel())

    def get_reward(self, physics: PlantPhysics) -> float:
        report = physics.last_report
        if report is not None and any(c.body == HULL for c in report.contacts):
            return 0.0
        error = float(np.linalg.norm(physics.plant.state()[:3] - self.ref[:3]))
        return float(rewards.tolerance(error, bounds=(0.0, 0.05), margin=1.0))


def load(scenario: str | Scenario = "wall-headon", mismatch: str = mismatches.DEFAULT, seed: int = 0,
         control_timestep: float = 0.1) -> control.Environment:
    """The environment of a scenario (name or Scenario), with the plant drawn from `mismatch`."""
    sc = get(scenario) if isinstance(scenario, str) else scenario
    params, _, plant, _ = build_plant(sc, mismatch, seed)
    h0, ref = initial_state(params, sc)
    return control.Environment(PlantPhysics.from_plant(plant), WallTask(sc, params, h0, ref),
                               time_limit=sc.duration, control_timestep=control_timestep)
