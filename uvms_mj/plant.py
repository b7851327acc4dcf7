"""The MuJoCo plant in the paper's terms: state h, input u held over a control period, reports.

Input policy: u outside its limits is CLIPPED to the limits (the report's `clipped` mask says which
entries were); u or h with the wrong length or a non-finite entry raises ValueError. MuJoCo's
warnings (bad qacc/qpos/qvel, contact or constraint buffer full) raise PlantUnstableError.

Added mass: the hull's armature plus the posture-dependent term A(q) of uvms_mj.added_mass, put
into MuJoCo's mass matrix at every physics step (exact, no iteration). A step whose mass matrix
cannot be factorized is counted in the report's `added_mass_failures` and warned about
(uvms_mj.added_mass.AddedMassSolveWarning).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import mujoco
import numpy as np

from uvms.conventions import mujoco_to_state, state_to_mujoco
from uvms.params import UVMSParams
from uvms.scene import Current, Scene
from uvms_mj.added_mass import AddedMass
from uvms_mj.build import EE_SITE, HULL, TIP_GEOM, BuildOptions, added_mass_terms, compile_model

_FATAL_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_CONTACTFULL,
    mujoco.mjtWarning.mjWARN_CNSTRFULL,
)


class PlantUnstableError(RuntimeError):
    """MuJoCo reported an unstable or overflowing simulation."""


class FaultMode(Enum):
    """How a failed thruster behaves."""

    ZERO = "zero"  # no force
    STUCK = "stuck"  # a constant force, whatever is commanded


@dataclass(frozen=True)
class ThrusterFault:
    """Thruster `thruster` (index or name) fails from `start_time` [s] on."""

    thruster: int | str
    start_time: float = 0.0
    mode: FaultMode = FaultMode.ZERO
    value: float = 0.0  # N, the stuck force (mode STUCK)


@dataclass(frozen=True)
class ContactReport:
    """Contact of one vehicle geom (of body `body`) with one plane over a control period."""

    geom: str
    body: str
    plane: str
    impulse: np.ndarray  # (3,) N s, world frame, force on the vehicle integrated over the period
    peak_normal_force: float  # N
    force: np.ndarray  # (3,) N, world frame, at the end of the period


@dataclass(frozen=True)
class PlantReport:
    """What the plant reports after a control period."""

    t: float  # s
    h: np.ndarray  # paper state at t
    u_applied: np.ndarray  # thruster forces [N] and joint torques [N m] actually applied at t
    clipped: np.ndarray  # bool mask: entries of the commanded u clipped to their limits
    contacts: tuple[ContactReport, ...]  # bodies touching a plane during the period
    ee_wrench: np.ndarray  # (6,) contact force [N] and torque about the EE point [N m], world, at t
    ee_impulse: np.ndarray  # (3,) N s, EE contact force integrated over the period
    wrist_impulse: np.ndarray  # (6,) N s, N m s: `wrist_wrench` integrated over the period
    distances: np.ndarray  # (n_geoms, n_planes) m, true signed distance of each geom to each plane
    added_mass_failures: int = 0  # physics steps of the period whose added-mass solve failed


@dataclass(frozen=True)
class PlantSettings:
    """Plant physics switches (see uvms_mj.build.BuildOptions) and faults."""

    build: BuildOptions = field(default_factory=BuildOptions)
    faults: tuple[ThrusterFault, ...] = ()


class Plant:
    """A UVMS in water with plane obstacles, stepped in control periods."""

    def __init__(self, params: UVMSParams, scene: Scene, settings: PlantSettings = PlantSettings()):
        self.params, self.scene, self.settings = params, scene, settings
        self.spec, self.model = compile_model(params, scene, settings.build)
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._fixed = settings.build.fixed_base
        self._hull = m.body(HULL).id
        self._n_thr = params.n_thrusters
        self._u_lo, self._u_hi = params.input_bounds()
        self.added_mass = AddedMass(m, added_mass_terms(params, scene.water.density, settings.build))
        self._faults = tuple(self._resolve_fault(f) for f in settings.faults)
        self._current: Current = scene.current
        self._ext = np.zeros((m.nbody, 6))
        self._has_ext = False
        self._tip = m.geom(TIP_GEOM).id if params.n_joints else -1
        self._ee_site = m.site(EE_SITE).id if params.n_joints else -1
        last = m.geom_bodyid[self._tip] if params.n_joints else -1
        self._last_link = {g for g in range(m.ngeom) if m.geom_bodyid[g] == last} if params.n_joints else set()
        plane_ids = [m.geom(f"plane_{p.name}").id for p in scene.planes]
        self.plane_names = tuple(p.name for p in scene.planes)
        self._plane_index = {g: i for i, g in enumerate(plane_ids)}
        self.geom_names = tuple(m.geom(g).name for g in range(m.ngeom) if m.geom_contype[g])
        self._vehicle_geoms = [m.geom(n).id for n in self.geom_names]
        self._geom_index = {g: i for i, g in enumerate(self._vehicle_geoms)}
        self._plane_ids = plane_ids
        self._warnings0 = np.zeros(len(_FATAL_WARNINGS), dtype=int)
        self._fromto = np.zeros(6)
        self._f6 = np.zeros(6)
        self.reset()

    # ----------------------------------------------------------------------------- state
    @property
    def t(self) -> float:
        return float(self.data.time)

    def reset(self, h: np.ndarray | None = None) -> None:
        """Reset to the `home` keyframe at rest, or to the paper state h; time to 0."""
        mujoco.mj_resetDataKeyframe(self.model, self.data, 0)
        if h is not None:
            self.set_state(h)
        self.model.opt.wind[:] = self._current.at(0.0)
        self._forward()
        self._warnings0 = self._warning_counts()

    def set_state(self, h: np.ndarray) -> None:
        """Set the paper state h (time unchanged)."""
        h = self._check_vector(h, self.params.n_states, "state h")
        nj = self.params.n_joints
        if self._fixed:
            self.data.qpos[:] = h[6:6 + nj]
            self.data.qvel[:] = h[12 + nj:]
        else:
            self.data.qpos[:], self.data.qvel[:] = state_to_mujoco(h, nj)
        self._forward()

    def state(self) -> np.ndarray:
        """The paper state h = [x y z phi theta psi q_m | v omega qdot_m]."""
        nj = self.params.n_joints
        if self._fixed:
            z = np.zeros(6)
            return np.concatenate([z, self.data.qpos, z, self.data.qvel])
        return mujoco_to_state(self.data.qpos, self.data.qvel, nj)

    def set_current(self, current: Current) -> None:
        """Replace the current profile (times are simulation times)."""
        self._current = current

    def set_external_wrench(self, body: str, wrench: np.ndarray) -> None:
        """A disturbance [N, N m], world frame, at the body's origin; held until changed."""
        w = self._check_vector(wrench, 6, "wrench")
        self._ext[self.model.body(body).id] = w
        self._has_ext = bool(np.any(self._ext != 0))

    def trim_weight(self) -> float:
        """The vehicle's weight in water [N] (positive: it sinks) as a trim check in still water measures
        it: the world-vertical force that holds the whole vehicle still at its present pose and
        posture, from MuJoCo's inverse dynamics at zero velocity and acceleration with the flow and
        contacts off (the plant's state is untouched)."""
        if self._fixed:
            raise ValueError("trim_weight of a fixed-base plant; allowed: a free-floating vehicle")
        m, d = self.model, mujoco.MjData(self.model)
        d.qpos[:] = self.data.qpos
        wind, flags = m.opt.wind.copy(), m.opt.disableflags
        m.opt.wind[:] = 0.0
        m.opt.disableflags = flags | mujoco.mjtDisableBit.mjDSBL_CONTACT
        try:
            mujoco.mj_inverse(m, d)
        finally:
            m.opt.wind[:], m.opt.disableflags = wind, flags
        return float(d.qfrc_inverse[2])

    # ----------------------------------------------------------------------------- stepping
    def step(self, u: np.ndarray, duration: float) -> PlantReport:
        """Hold u (zero-order) for `duration` seconds of physics steps and report."""
        u = self._check_vector(u, self.params.n_inputs, "input u")
        n = round(duration / self.model.opt.timestep)
        if n < 1 or abs(n * self.model.opt.timestep - duration) > 1e-9:
            raise ValueError(f"duration {duration} s is not allowed; allowed: a positive multiple "
                             f"of the physics timestep {self.model.opt.timestep} s")
        u_cmd = np.clip(u, self._u_lo, self._u_hi)
        clipped = u_cmd != u
        acc: dict[tuple[int, int], list] = {}
        ee_imp, wrist_imp = np.zeros(3), np.zeros(6)
        dt = self.model.opt.timestep
        failures0 = self.added_mass.failures
        for _ in range(n):
            self._physics_step(u_cmd)
            for key, f_world, pos in self._contacts():
                rec = acc.setdefault(key, [np.zeros(3), 0.0])
                rec[0] += f_world * dt
                rec[1] = max(rec[1], float(f_world @ self.scene.planes[key[1]].normal))
                geom = self._vehicle_geoms[key[0]]
                if geom == self._tip:
                    ee_imp += f_world * dt
                if geom in self._last_link:
                    wrist_imp[:3] += f_world * dt
                    wrist_imp[3:] += _cross(pos - self.data.site_xpos[self._ee_site], f_world) * dt
        self._raise_on_warnings()
        return self._report(clipped, acc, ee_imp, wrist_imp, self.added_mass.failures - failures0)

    def acceleration(self, u: np.ndarray) -> np.ndarray:
        """The paper's nu_dot [m/s^2, rad/s^2] at the current state under u (clipped, faults
        applied): the plant's forward dynamics, added mass included; time does not advance."""
        u = self._check_vector(u, self.params.n_inputs, "input u")
        self._prepare(np.clip(u, self._u_lo, self._u_hi))
        self._forward()
        d = self.data
        if self._fixed:
            return np.concatenate([np.zeros(6), d.qacc])
        R = d.xmat[self._hull].reshape(3, 3)
        v_body, omega = R.T @ d.qvel[0:3], d.qvel[3:6]
        # qvel[0:3] = R v, so qacc[0:3] = R (omega x v) + R v_dot
        return np.concatenate([R.T @ d.qacc[0:3] - _cross(omega, v_body), d.qacc[3:]])

    def _prepare(self, u: np.ndarray) -> None:
        """Controls (faults applied), the current and the external wrenches at the present time."""
        m, d = self.model, self.data
        d.ctrl[:] = u
        for idx, f in self._faults:
            if d.time >= f.start_time:
                d.ctrl[idx] = 0.0 if f.mode is FaultMode.ZERO else f.value
        m.opt.wind[:] = self._current.at(d.time)
        self._apply_xfrc()

    def _forward(self) -> None:
        """mj_forward with the added mass in the mass matrix (uvms_mj.added_mass)."""
        m, d = self.model, self.data
        if not self.added_mass.active:
            mujoco.mj_forward(m, d)
            return
        mujoco.mj_fwdPosition(m, d)
        mujoco.mj_sensorPos(m, d)
        self.added_mass.apply(d)
        mujoco.mj_forwardSkip(m, d, mujoco.mjtStage.mjSTAGE_POS, 0)

    def _physics_step(self, u: np.ndarray) -> None:
        m, d = self.model, self.data
        self._prepare(u)
        mujoco.mj_checkPos(m, d)
        mujoco.mj_checkVel(m, d)
        self._forward()
        mujoco.mj_checkAcc(m, d)
        mujoco.mj_implicit(m, d)  # implicitfast: solves with data.M, the added mass included

    def _apply_xfrc(self) -> None:
        """External wrenches act at body origins; xfrc_applied acts at the CoM: shift torques."""
        d = self.data
        d.xfrc_applied[:] = 0.0
        if self._has_ext:
            for b in np.flatnonzero(np.any(self._ext != 0, axis=1)):
                f, tau = self._ext[b, :3], self._ext[b, 3:]
                d.xfrc_applied[b, :3] += f
                d.xfrc_applied[b, 3:] += tau + _cross(d.xpos[b] - d.xipos[b], f)

    # ----------------------------------------------------------------------------- reports
    def _contacts(self):
        """Yield ((vehicle geom index, plane index), force on the vehicle [N, world], position)."""
        m, d = self.model, self.data
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = c.geom1, c.geom2
            if g1 in self._plane_index and g2 in self._geom_index:
                plane, veh, sign = self._plane_index[g1], self._geom_index[g2], 1.0
            elif g2 in self._plane_index and g1 in self._geom_index:
                plane, veh, sign = self._plane_index[g2], self._geom_index[g1], -1.0
            else:
                continue
            mujoco.mj_contactForce(m, d, i, self._f6)
            # The contact-frame force acts on geom2; rows of `frame` are the frame's axes.
            f_world = sign * (c.frame.reshape(3, 3).T @ self._f6[:3])
            yield (veh, plane), f_world, c.pos.copy()

    def ee_wrench(self) -> np.ndarray:
        """End-effector contact wrench now: force [N] and torque about the EE point [N m], world."""
        return self._wrench_on({self._tip})

    def wrist_wrench(self) -> np.ndarray:
        """What a force/torque sensor between the last joint and the arm's last link reads once
        tared (its link's own weight, buoyancy, inertia and fluid load taken out): the contact
        wrench on that link and its tip, force [N] and torque about the EE point [N m], world."""
        return self._wrench_on(self._last_link)

    def _wrench_on(self, geoms: set[int]) -> np.ndarray:
        """The contact force [N] on those geoms now and its torque about the EE point [N m], world."""
        w = np.zeros(6)
        if self._tip < 0:
            return w
        p_ee = self.data.site_xpos[self._ee_site]
        for (veh, _plane), f, pos in self._contacts():
            if self._vehicle_geoms[veh] in geoms:
                w[:3] += f
                w[3:] += _cross(pos - p_ee, f)
        return w

    def signed_distances(self) -> np.ndarray:
        """True signed distance [m] of every vehicle geom (rows) to every plane (columns)."""
        m, d = self.model, self.data
        out = np.empty((len(self._vehicle_geoms), len(self._plane_ids)))
        for i, g in enumerate(self._vehicle_geoms):
            for j, p in enumerate(self._plane_ids):
                out[i, j] = mujoco.mj_geomDistance(m, d, g, p, 1e3, self._fromto)
        return out

    def applied_input(self) -> np.ndarray:
        """Thruster forces [N] and joint torques [N m] that MuJoCo is applying now."""
        return self.data.actuator_force.copy()

    def _report(self, clipped: np.ndarray, acc: dict, ee_imp: np.ndarray, wrist_imp: np.ndarray,
                failures: int) -> PlantReport:
        now = {k: f for k, f, _ in self._contacts()}
        contacts = tuple(
            ContactReport(geom=self.geom_names[k[0]], body=self._body_of(self._vehicle_geoms[k[0]]),
                          plane=self.plane_names[k[1]],
                          impulse=imp, peak_normal_force=peak, force=now.get(k, np.zeros(3)))
            for k, (imp, peak) in sorted(acc.items()))
        return PlantReport(t=self.t, h=self.state(), u_applied=self.applied_input(), clipped=clipped,
                           contacts=contacts, ee_wrench=self.ee_wrench(), ee_impulse=ee_imp,
                           wrist_impulse=wrist_imp,
                           distances=self.signed_distances(), added_mass_failures=failures)

    def _body_of(self, geom: int) -> str:
        return self.model.body(self.model.geom_bodyid[geom]).name

    # ----------------------------------------------------------------------------- checks
    def _warning_counts(self) -> np.ndarray:
        return np.array([self.data.warning[w].number for w in _FATAL_WARNINGS])

    def _raise_on_warnings(self) -> None:
        now = self._warning_counts()
        new = np.flatnonzero(now > self._warnings0)
        if new.size:
            names = ", ".join(_FATAL_WARNINGS[i].name for i in new)
            raise PlantUnstableError(f"MuJoCo warned {names} before t = {self.t:.4f} s: the "
                                     "simulation is unstable (too large a force or timestep?)")

    @staticmethod
    def _check_vector(v: np.ndarray, n: int, what: str) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        if v.shape != (n,):
            raise ValueError(f"{what} has shape {v.shape}; allowed: ({n},)")
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{what} has non-finite entries at {np.flatnonzero(~np.isfinite(v)).tolist()}; "
                             "allowed: finite numbers")
        return v

    def _resolve_fault(self, f: ThrusterFault) -> tuple[int, ThrusterFault]:
        names = [t.name for t in self.params.thrusters]
        idx = names.index(f.thruster) if isinstance(f.thruster, str) and f.thruster in names else f.thruster
        if not isinstance(idx, int) or not 0 <= idx < self._n_thr:
            raise ValueError(f"thruster fault {f.thruster!r} is not allowed; allowed: an index "
                             f"0..{self._n_thr - 1} or one of {', '.join(names)}")
        return idx, f


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of two 3-vectors (np.cross costs ~20 us a call)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


__all__ = ["ContactReport", "FaultMode", "Plant", "PlantReport", "PlantSettings", "PlantUnstableError",
           "ThrusterFault"]
