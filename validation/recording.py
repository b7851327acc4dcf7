"""A Rerun recording of a closed-loop run: MuJoCo's geometry moving over sim time, the
controller's superellipsoids overlaid, force arrows, predicted horizons, telemetry and the mode as a
state timeline, with a blueprint that puts the 3D view beside the plots.

Entities: `world/planes/<name>` (boxes), `world/mujoco/<geom>` (MuJoCo's ellipsoid, capsules and
tip sphere, posed each step), `world/model/<body>` (the controller's superellipsoid meshes posed by
the model at the measured state), `world/forces/thrusters` and `world/forces/tip` (arrows, N / 50),
`world/plan/hull` and `world/plan/tip` (predicted horizons, line strips), `telemetry/...` (scalars;
`telemetry/model/...`: the current [m/s] and extra hull weight [N] the model assumed),
`mode` (state changes) and `run` (a text document: the scenario, the controller and its resolved
settings, the mismatch draw and, at the end, the verdict). Timeline: `sim_time`.
"""

from __future__ import annotations

import json

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from mujoco import mjtGeom

from controller.model import UVMSModel
from controller.protocol import StepInfo, label
from uvms.conventions import euler_zyx_to_matrix
from uvms.params import UVMSParams
from uvms.scene import Water
from uvms_mj.plant import Plant, PlantReport

FORCE_SCALE = 1.0 / 50.0  # m per N for arrows


class RunRecording:
    """Log a run to an .rrd file (no viewer needed)."""

    def __init__(self, path, plant: Plant, params: UVMSParams, water: Water, name: str):
        """`params`: the controller's (nominal) vehicle, whose superellipsoids are overlaid."""
        model = UVMSModel(params, water)
        self.plant, self.model = plant, model
        self._header = ""
        self.rec = rr.RecordingStream("uvms_testbed", recording_id=name)
        self.rec.set_log_time_enabled(False)
        self.rec.save(str(path))
        self.rec.send_blueprint(self.blueprint())
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for p in plant.scene.planes:
            n = np.asarray(p.normal)
            centre = -p.offset * n + (np.array([0.0, 0.0, 0.0]) if abs(n[2]) > 0.9 else np.array([0.0, 0.0, -1.5]))
            half = np.where(np.abs(n) > 0.9, 0.005, 3.0)
            self.rec.log(f"world/planes/{p.name}", rr.Boxes3D(centers=[centre], half_sizes=[half],
                                                              colors=[(120, 120, 140, 80)]), static=True)
        m = plant.model
        self._geoms = []
        for name in plant.geom_names:
            g = m.geom(name)
            size, kind = np.array(g.size), int(g.type[0])
            path = f"world/mujoco/{name}"
            if kind == mjtGeom.mjGEOM_CAPSULE:
                self.rec.log(path, rr.Capsules3D(lengths=[2 * size[1]], radii=[size[0]],
                                                 translations=[[0.0, 0.0, -size[1]]], colors=[(230, 160, 40)]),
                             static=True)
            elif kind in (mjtGeom.mjGEOM_ELLIPSOID, mjtGeom.mjGEOM_SPHERE):
                half = size if kind == mjtGeom.mjGEOM_ELLIPSOID else np.full(3, size[0])
                self.rec.log(path, rr.Ellipsoids3D(half_sizes=[half], colors=[(60, 140, 230)]), static=True)
            else:
                continue
            self._geoms.append((g.id, path))
        for body, mesh in model.body_meshes(resolution=24).items():
            self.rec.log(f"world/model/{body}", rr.Mesh3D(vertex_positions=mesh.vertices, triangle_indices=mesh.faces,
                                                          albedo_factor=(120, 230, 120, 70)), static=True)
        self._mode = None

    def describe(self, **facts: object) -> None:
        """The run's facts (scenario, controller, settings, mismatch...) as the `run` document."""
        self._header = "\n\n".join(f"## {k}\n\n```json\n{json.dumps(v, indent=1, default=str)}\n```"
                                    for k, v in facts.items())
        self.rec.log("run", rr.TextDocument(self._header, media_type=rr.MediaType.MARKDOWN), static=True)

    def verdict(self, verdict: str, reason: str) -> None:
        """The verdict, on top of the run's facts."""
        text = f"# Verdict: {verdict}\n\n{reason}\n\n{self._header}"
        self.rec.log("run", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True)
        self.rec.flush()

    @staticmethod
    def blueprint() -> rrb.Blueprint:
        return rrb.Blueprint(rrb.Horizontal(
            rrb.Vertical(rrb.Spatial3DView(origin="world", name="UVMS"), rrb.TextDocumentView(origin="run", name="run"),
                         row_shares=[3, 1]),
            rrb.Vertical(
                rrb.StateTimelineView(origin="mode", name="mode") if hasattr(rrb, "StateTimelineView")
                else rrb.TextLogView(origin="mode"),
                rrb.TimeSeriesView(origin="telemetry/distance", name="distances [m]"),
                rrb.TimeSeriesView(origin="telemetry/closing_speed", name="hull closing speed [m/s]"),
                rrb.TimeSeriesView(origin="telemetry/input", name="inputs [N, N m]"),
                rrb.TimeSeriesView(origin="telemetry/solver", name="solve time [s], dt [s], N_p"),
                rrb.TimeSeriesView(origin="telemetry/model", name="model's current [m/s], extra weight [N]"),
            ), column_shares=[3, 2]))

    def observe(self, t_start: float, report: PlantReport, info: StepInfo, u: np.ndarray) -> None:
        """One physics piece (validation.observers), logged at its end time report.t [s]."""
        rec, plant, model, t = self.rec, self.plant, self.model, report.t
        rec.set_time("sim_time", duration=t)
        d = plant.data
        for gid, path in self._geoms:
            rec.log(path, rr.Transform3D(translation=d.geom_xpos[gid], mat3x3=d.geom_xmat[gid].reshape(3, 3)))
        h = report.h
        poses = model.superellipsoid_poses(h)
        nb = len(model.body_names)
        for k, body in enumerate(model.body_names):
            rec.log(f"world/model/{body}", rr.Transform3D(translation=np.asarray(poses[k]).ravel(),
                                                         mat3x3=np.asarray(poses[nb + k])))
        R = euler_zyx_to_matrix(*h[3:6])
        p = plant.params
        origins = [h[:3] + R @ th.position for th in p.thrusters]
        vectors = [R @ th.direction * ui * FORCE_SCALE for th, ui in zip(p.thrusters, u, strict=False)]
        rec.log("world/forces/thrusters", rr.Arrows3D(origins=origins, vectors=vectors, colors=[(230, 60, 60)]))
        x_tip = np.asarray(model.ee_pose(h)[0]).ravel()
        rec.log("world/forces/tip", rr.Arrows3D(origins=[x_tip], vectors=[report.ee_wrench[:3] * FORCE_SCALE],
                                                colors=[(250, 220, 40)]))
        for i, geom in enumerate(plant.geom_names):
            for j, plane in enumerate(plant.plane_names):
                rec.log(f"telemetry/distance/{plane}/{geom}", rr.Scalars(float(report.distances[i, j])))
        for k, name in enumerate([th.name for th in p.thrusters] + [lk.name for lk in p.arm.links]):
            rec.log(f"telemetry/input/{name}", rr.Scalars(float(u[k])))
        rec.log("telemetry/contact/tip_force", rr.Scalars(float(np.linalg.norm(report.ee_wrench[:3]))))
        mode = label(info.mode)
        if mode != self._mode:
            self._mode = mode
            rec.log("mode", rr.StateChange(state=f"Mode {mode}" if mode in ("I", "II", "III") else mode))
        plane = info.contact_plane if info.contact_plane is not None else 0
        if info.closing_speeds is not None:
            rec.log("telemetry/closing_speed/hull", rr.Scalars(float(info.closing_speeds[plane, 0])))
        if t_start == info.t:  # once a step
            rec.log("telemetry/solver/solve_time", rr.Scalars(info.solve_time))
            rec.log("telemetry/solver/dt", rr.Scalars(info.dt))
            rec.log("telemetry/solver/horizon", rr.Scalars(float(info.horizon)))
            if info.water is not None:  # what the model assumed: the current and the hull's extra weight
                for k, name in enumerate(("current_x", "current_y", "current_z", "extra_weight")):
                    rec.log(f"telemetry/model/{name}", rr.Scalars(float(info.water[k])))
        if info.h_pred is not None and len(info.h_pred) > 1:
            rec.log("world/plan/hull", rr.LineStrips3D([info.h_pred[:, :3]], colors=[(60, 200, 255)]))
            tips = [np.asarray(model.ee_pose(x)[0]).ravel() for x in info.h_pred]
            rec.log("world/plan/tip", rr.LineStrips3D([tips], colors=[(255, 200, 60)]))

    def close(self) -> None:
        self.rec.flush()
        self.rec.disconnect()
