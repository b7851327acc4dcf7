"""Build the MuJoCo plant (an `mujoco.MjSpec`) from vehicle parameters and a scene.

What MuJoCo does not do by itself, and how the plant does it:

- Buoyancy: MuJoCo has none. Every body gets a welded child body `<body>_cob` at its centre of
  buoyancy with a tiny mass `COB_MASS` and `gravcomp = rho V / COB_MASS`: an upward force
  rho V g at the centre of buoyancy. The parent's mass, centre of mass and inertia are reduced
  by the child's (its inertia `COB_INERTIA` and its parallel-axis term) so that the composite
  equals the parameter file exactly.
- Added mass: MuJoCo's ellipsoid fluid model has no inertial -M_A dv/dt term. The hull's
  rotational added inertia and an isotropic translational part (the mid-range of the three
  translational added masses) go into the free joint's per-DOF armature, set after compile
  (`<body simple="false">` keeps the solver from ignoring it; exact: the rotational DOFs are in
  the body frame and an isotropic mass is frame-free). The anisotropic translational remainder
  and each link's cross-flow added-mass tensor (in its own frame, about its centre, as the
  paper's model has it) are added to MuJoCo's mass matrix at every step by the plant
  (`added_mass_terms`, uvms_mj.added_mass): they follow the posture and couple with the hull.
  The hinges' armature is the rotor inertia reflected through each joint's gearbox alone.
- The velocity-dependent fluid forces (drag, lift, added-mass Coriolis and Munk moments) are
  MuJoCo's own ellipsoid model on each geom: the plant's physics, not the paper's Fossen terms.
  MuJoCo derives the added-mass part from the ellipsoid's potential-flow virtual mass, so the hull
  carries the fluid model on a separate, non-colliding ellipsoid `hull_fluid` whose semi-axes are
  solved for so that its virtual mass equals the parameter file's translational added mass (the
  collision ellipsoid, the frame's bounding box, would have 2-5 times the Munk moments).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.polynomial.legendre import leggauss

from uvms.params import Arm, UVMSParams, parallel_axis
from uvms.scene import Scene
from uvms_mj.added_mass import AddedMassTerm

COB_MASS = 1e-3  # kg, mass of each centre-of-buoyancy body (taken from its parent)
COB_INERTIA = 1e-9  # kg m^2, principal inertia of each centre-of-buoyancy body (taken from its parent)
HULL = "hull"
ROOT_JOINT = "root"
EE_SITE = "ee"
TIP_GEOM = "ee_tip"
VEHICLE_CLASS = "vehicle"
OBSTACLE_CLASS = "obstacle"


@dataclass(frozen=True)
class BuildOptions:
    """Switches for physics experiments; the defaults are the full plant."""

    timestep: float = 0.002  # s
    fluid: bool = True  # MuJoCo's ellipsoid fluid forces
    buoyancy: bool = True
    gravity: bool = True
    added_mass: bool = True
    joint_damping: bool = True  # the parameter file's gearbox friction (not in the paper's model)
    joint_limits: bool = True  # joint range as a MuJoCo limit (the paper's model leaves it to the OCP)
    fixed_base: bool = False  # hull welded to the world (manipulation experiments)

    def __post_init__(self) -> None:
        if not 0 < self.timestep <= 0.01:
            raise ValueError(f"timestep {self.timestep} s is not allowed; allowed: 0 < timestep <= 0.01 s")


_GAUSS_T, _GAUSS_W = leggauss(200)


def ellipsoid_virtual_mass(semi_axes: np.ndarray, rho: float) -> np.ndarray:
    """Potential-flow added mass [kg] of an ellipsoid along its axes (Lamb 1932, section 373; the
    formula MuJoCo's ellipsoid fluid model uses): rho V k_i / (2 - k_i), with
    k_i = abc int_0^inf dl / ((r_i^2 + l) sqrt((a^2 + l)(b^2 + l)(c^2 + l))). A sphere gives rho V / 2."""
    s = np.asarray(semi_axes, float)
    t, w = 0.5 * (_GAUSS_T + 1), 0.5 * _GAUSS_W
    scale = float(np.mean(s)) ** 2
    lam, dlam = scale * t / (1 - t), scale / (1 - t) ** 2  # maps [0, 1) onto [0, inf)
    delta = np.sqrt(np.prod([r * r + lam for r in s], axis=0))
    k = np.array([np.prod(s) * np.sum(w * dlam / ((r * r + lam) * delta)) for r in s])
    return rho * (4 / 3) * np.pi * np.prod(s) * k / (2 - k)


def fluid_proxy_semi_axes(added_mass: np.ndarray, rho: float) -> np.ndarray:
    """Semi-axes [m] of the ellipsoid whose virtual mass is `added_mass` (3,) [kg] (Newton on logs)."""
    target = np.log(np.asarray(added_mass, float))
    x = np.log(np.cbrt(np.asarray(added_mass) / (0.5 * rho * 4 / 3 * np.pi)))  # spheres of that mass
    for _ in range(50):
        f = np.log(ellipsoid_virtual_mass(np.exp(x), rho)) - target
        if np.max(np.abs(f)) < 1e-12:
            return np.exp(x)
        J = np.column_stack([(np.log(ellipsoid_virtual_mass(np.exp(x + e), rho)) - target - f) / 1e-7
                             for e in 1e-7 * np.eye(3)])
        x = x - np.linalg.solve(J, f)
    raise ValueError(f"added mass {added_mass} kg: no ellipsoid has this virtual mass in water of {rho} kg/m^3")


def quat_z_to(direction: np.ndarray) -> np.ndarray:
    """Quaternion (w, x, y, z) of the smallest rotation taking +z onto `direction`."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    if d[2] < -1 + 1e-12:
        return np.array([0.0, 1.0, 0.0, 0.0])
    q = np.array([1.0 + d[2], -d[1], d[0], 0.0])
    return q / np.linalg.norm(q)


def _parent_without_cob(mass: float, com: np.ndarray, inertia: np.ndarray, cob: np.ndarray,
                        ) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, CoM and full inertia (about its CoM) that, with the centre-of-buoyancy body (mass
    COB_MASS at `cob`, isotropic inertia COB_INERTIA about it), give the composite exactly (mass,
    com, inertia about com: a (3,) principal diagonal or a (3, 3) matrix)."""
    m = mass - COB_MASS
    c = (mass * com - COB_MASS * cob) / m
    full = (_as_matrix(inertia) - COB_INERTIA * np.eye(3) - COB_MASS * parallel_axis(cob - com)
            - m * parallel_axis(c - com))
    return m, c, full


def _as_matrix(inertia: np.ndarray) -> np.ndarray:
    inertia = np.asarray(inertia, float)
    return np.diag(inertia) if inertia.shape == (3,) else inertia


def _set_inertial(body: mujoco.MjsBody, mass: float, com: np.ndarray, inertia: np.ndarray,
                  cob: np.ndarray, volume: float, rho: float, buoyancy: bool) -> None:
    body.explicitinertial = True
    if not buoyancy:
        full = _as_matrix(inertia)
        body.mass, body.ipos = mass, com
        body.fullinertia = [full[0, 0], full[1, 1], full[2, 2], full[0, 1], full[0, 2], full[1, 2]]
        return
    m, c, full = _parent_without_cob(mass, com, inertia, cob)
    body.mass, body.ipos = m, c
    body.fullinertia = [full[0, 0], full[1, 1], full[2, 2], full[0, 1], full[0, 2], full[1, 2]]
    # The child sits at the parent's origin with its CoM at the CoB (gravcomp acts at the CoM).
    child = body.add_body(name=f"{body.name}_cob")
    child.explicitinertial = True
    child.mass, child.ipos = COB_MASS, cob
    child.inertia = [COB_INERTIA] * 3
    child.gravcomp = rho * volume / COB_MASS
    # MuJoCo applies its inertia-box fluid model to a body without ellipsoid-model geoms; a 1 mm
    # non-colliding sphere with zero coefficients opts the CoB body into the (here negligible)
    # ellipsoid model instead.
    child.add_geom(name=f"{body.name}_cob_marker", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=cob, size=[1e-3, 0, 0],
                   contype=0, conaffinity=0, group=4, density=0.0, fluid_ellipsoid=1, fluid_coefs=[0, 0, 0, 0, 0])


def _defaults(spec: mujoco.MjSpec, arm: Arm) -> None:
    veh = spec.add_default(VEHICLE_CLASS, spec.default)
    veh.geom.contype, veh.geom.conaffinity, veh.geom.condim = 1, 0, 3
    veh.geom.friction = [0.0, 0.0, 0.0]  # the obstacle's friction rules (higher priority)
    veh.geom.fluid_ellipsoid = 1
    veh.geom.group = 0
    veh.geom.density = 0.0
    obs = spec.add_default(OBSTACLE_CLASS, spec.default)
    obs.geom.contype, obs.geom.conaffinity, obs.geom.priority = 0, 1, 1
    # the obstacle's higher priority makes its contact parameters the contact's: the arm's soft contact
    obs.geom.solref = [arm.contact_time_constant, 1.0]
    obs.geom.solimp = [obs.geom.solimp[0], arm.contact_impedance, *obs.geom.solimp[2:]]
    obs.geom.group = 1


def hull_armature(params: UVMSParams) -> np.ndarray:
    """Free-joint armature [kg x3, kg m^2 x3]: isotropic translational part, rotational added mass."""
    ma = params.hull.added_mass
    iso = 0.5 * (ma[:3].min() + ma[:3].max())
    return np.concatenate([[iso] * 3, ma[3:]])


def hull_added_mass_remainder(params: UVMSParams) -> np.ndarray:
    """Body-frame diagonal translational added mass [kg] not carried by the armature."""
    return params.hull.added_mass[:3] - hull_armature(params)[:3]


def build_spec(params: UVMSParams, scene: Scene, options: BuildOptions = BuildOptions()) -> mujoco.MjSpec:
    """The plant as an MjSpec: every element named, default classes, a keyframe `home`."""
    rho = scene.water.density
    spec = mujoco.MjSpec()
    spec.modelname = f"{params.name}_{params.arm.name}_{scene.name}"
    spec.compiler.degree = False
    opt = spec.option
    opt.timestep = options.timestep
    opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC  # Coulomb cone |F_t| <= mu F_n, as in the paper
    opt.noslip_iterations = 5  # removes the creep of soft friction under sustained load
    opt.gravity = [0.0, 0.0, -scene.water.gravity if options.gravity else 0.0]
    opt.density = rho if options.fluid else 0.0
    opt.viscosity = scene.water.viscosity if options.fluid else 0.0
    opt.wind = scene.current.at(0.0)
    spec.visual.global_.offwidth, spec.visual.global_.offheight = 1280, 720
    _defaults(spec, params.arm)
    _scene_geometry(spec, scene)
    buoy = options.buoyancy

    hull = spec.worldbody.add_body(name=HULL)
    hull.simple = 0  # keep per-DOF armature set after compile in the dynamics
    h = params.hull
    _set_inertial(hull, h.mass, h.com, h.inertia, h.cob, h.volume, rho, buoy)
    if not options.fixed_base:
        hull.add_joint(name=ROOT_JOINT, type=mujoco.mjtJoint.mjJNT_FREE)
    vcls = spec.find_default(VEHICLE_CLASS)
    hull.add_geom(name="hull_geom", default=vcls, type=mujoco.mjtGeom.mjGEOM_ELLIPSOID,
                  size=h.size / 2, fluid_ellipsoid=0, rgba=[0.15, 0.35, 0.8, 0.9])
    hull.add_geom(name="hull_fluid", default=vcls, type=mujoco.mjtGeom.mjGEOM_ELLIPSOID,
                  size=fluid_proxy_semi_axes(h.added_mass[:3], rho), contype=0, group=3,
                  fluid_coefs=h.mujoco_fluidcoef, rgba=[0.3, 0.8, 0.9, 0.3])
    for t in params.thrusters:
        hull.add_site(name=t.name, pos=t.position, quat=quat_z_to(t.direction),
                      type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.03, 0.02, 0], rgba=[0.9, 0.6, 0.1, 1])
    # from the side (world -y) and a little above, level with the hull in x (so on the water side of
    # a wall ahead) and turned towards its front, following its centre of mass: the hull, the arm and
    # a wall up to about 1 m ahead stay in frame
    hull.add_camera(name="chase", pos=[0.0, -3.0, 0.8], mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM,
                    quat=_look_quat(np.array([0.45, 3.0, -0.8])))

    parent, offset = hull, np.asarray(h.arm_mount)
    for i, lk in enumerate(params.arm.links):
        body = parent.add_body(name=lk.name, pos=offset)
        _set_inertial(body, lk.mass, lk.com, lk.inertia, lk.cob, lk.volume, rho, buoy)
        body.add_joint(name=f"{lk.name}_joint", type=mujoco.mjtJoint.mjJNT_HINGE, axis=lk.joint_axis,
                       range=lk.joint_range, limited=int(options.joint_limits),
                       damping=lk.joint_damping if options.joint_damping else 0.0)
        body.add_geom(name=f"{lk.name}_geom", default=vcls, type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                      fromto=[0, 0, 0, lk.length, 0, 0], size=[lk.radius, 0, 0],
                      fluid_coefs=lk.mujoco_fluidcoef, rgba=[0.75, 0.75, 0.72, 1])
        if i == params.arm.n_joints - 1:
            ee = params.arm.end_effector
            body.add_geom(name=TIP_GEOM, default=vcls, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          pos=ee, size=[params.arm.tip_radius, 0, 0], rgba=[0.9, 0.2, 0.2, 1])
            body.add_site(name=EE_SITE, pos=ee, size=[0.005, 0, 0])
        parent, offset = body, np.array([lk.length, 0.0, 0.0])

    for t in params.thrusters:
        spec.add_actuator(name=t.name, target=t.name, trntype=mujoco.mjtTrn.mjTRN_SITE,
                          gear=[0, 0, 1, 0, 0, 0], ctrllimited=1, ctrlrange=t.force_range)
    for lk in params.arm.links:
        spec.add_actuator(name=f"{lk.name}_motor", target=f"{lk.name}_joint",
                          trntype=mujoco.mjtTrn.mjTRN_JOINT, gear=[1, 0, 0, 0, 0, 0],
                          ctrllimited=1, ctrlrange=[-lk.torque_limit, lk.torque_limit])
    base = [] if options.fixed_base else [0, 0, 0, 1, 0, 0, 0]
    spec.add_key(name="home", qpos=np.concatenate([base, params.arm.home]))
    for lk in params.arm.links:
        spec.joint(f"{lk.name}_joint").armature = lk.rotor_inertia
    return spec


def _look_quat(forward: np.ndarray) -> np.ndarray:
    """Camera quaternion looking along `forward` with world z up (camera looks along its -z)."""
    f = forward / np.linalg.norm(forward)
    right = np.cross(f, [0, 0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, f)
    R = np.column_stack([right, up, -f])
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, R.ravel())
    return q


def _scene_geometry(spec: mujoco.MjSpec, scene: Scene) -> None:
    spec.add_texture(name="water", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.1, 0.35, 0.5],
                     rgb2=[0.0, 0.05, 0.1], width=256, height=256)
    spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.25, 0.3, 0.3],
                     rgb2=[0.35, 0.4, 0.4], width=256, height=256)
    spec.add_material(name="grid", textures=["", "grid"], texrepeat=[4, 4], reflectance=0.0)
    spec.add_texture(name="wall", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.55, 0.5, 0.4],
                     rgb2=[0.65, 0.6, 0.5], width=256, height=256)
    spec.add_material(name="wall", textures=["", "wall"], texrepeat=[8, 8], reflectance=0.0, emission=0.3)
    spec.worldbody.add_light(name="sun", pos=[0, 0, 6], dir=[0, 0.2, -1], castshadow=False)
    obs = spec.find_default(OBSTACLE_CLASS)
    for p in scene.planes:
        spec.worldbody.add_geom(
            name=f"plane_{p.name}", default=obs, type=mujoco.mjtGeom.mjGEOM_PLANE,
            pos=p.point, quat=quat_z_to(p.normal), size=[10, 10, 0.25],
            material="grid" if abs(p.normal[2]) > 0.7 else "wall",  # seafloor-like or wall-like
            friction=[p.friction, 0.005, 0.0001], condim=3 if p.friction > 0 else 1)


def added_mass_terms(params: UVMSParams, rho: float, options: BuildOptions = BuildOptions(),
                     ) -> tuple[AddedMassTerm, ...]:
    """The added mass the plant adds to MuJoCo's mass matrix (the rest is the hull's armature):
    the hull's translational remainder about its origin (none with a fixed base) and every link's
    cross-flow tensor about its centre (`Link.added_mass` in water of density rho [kg/m^3])."""
    if not options.added_mass:
        return ()
    hull = () if options.fixed_base else (
        AddedMassTerm(HULL, np.zeros(3), np.concatenate([hull_added_mass_remainder(params), np.zeros(3)])),)
    return hull + tuple(AddedMassTerm(lk.name, np.array([lk.length / 2, 0.0, 0.0]), lk.added_mass(rho))
                        for lk in params.arm.links)


def compile_model(params: UVMSParams, scene: Scene, options: BuildOptions = BuildOptions(),
                  ) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
    """Compile the plant and set the per-DOF free-joint armature (not expressible in MJCF)."""
    spec = build_spec(params, scene, options)
    model = spec.compile()
    if options.added_mass and not options.fixed_base:
        dof = model.joint(ROOT_JOINT).dofadr[0]
        model.dof_armature[dof:dof + 6] = hull_armature(params)
    return spec, model
