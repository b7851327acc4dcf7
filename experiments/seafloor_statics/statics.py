"""Whether a heavy vehicle with every thruster dead can keep its hull off the seafloor, per draw.

PYTHONPATH=. python experiments/seafloor_statics/statics.py --out FILE.csv [--mismatch wide]
    [--seeds 8368-8397] [--max-pitch DEG]    (writes FILE.csv and FILE.manifest.json)

For each mismatch draw of thrusters-dead, the plant's own parameters (validation.mismatch.apply)
go into the controller's Kane model, as in ../thrusters_dead_statics, and IPOPT answers two questions:

1. The slowest slide down the wall: among the steady states with the tip on the wall (the vehicle
   at rest or sliding at a constant vertical speed w, no rotation, Mode III's smooth friction law, the
   joints' torques and the jaws' limit respected, the hull and the other links off the wall), the one
   with the smallest w^2. With the hull's height above the seafloor at the start, h_floor / |w| is
   how long the wall alone keeps it off the seafloor.
2. The best floor strut: the steady state at rest with the tip on the seafloor (any friction
   force within the cone |F_t| <= mu F_n, more than the sliding law allows), the hull, the links and
   the tip off the wall, the links off the seafloor, |pitch| <= max_pitch, that keeps the hull
   furthest above the seafloor; then the drawn MuJoCo plant started there, its joints held at those
   angles by those torques plus a PD, for 2 s (../thrusters_dead_statics' oracle).

A steady state is evidence, not a proof: the closed loop starts moving, and the transients matter.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

from controller.kinematics import euler_zyx
from controller.model import UVMSModel, water
from controller.transcription import obstacle_frame, tip_gap
from experiments.thrusters_dead_statics.statics import DELTA, held_in_mujoco, seeds
from uvms import load_params
from validation import manifest, mismatch
from validation.scenarios import get
from validation.setup import scene_of

SCENARIO = "thrusters-dead"
ARMS = ([0.0, 1.0, 0.5, 0.0], [0.0, 0.3, 0.3, 0.0], [0.0, -0.5, 0.5, 0.0], [0.0, 1.6, 1.5, 0.0], [0.0, 1.2, 1.2, 1.0])
PITCHES = (0.0, 0.3, -0.3, 0.6, -0.6)


def _setup(seed: int, spec: str):
    sc = get(SCENARIO)
    params, scene = load_params(arm=sc.arm), scene_of(sc)
    drawn = mismatch.draw(spec, seed)
    plant_params, plant_scene, extra, _ = mismatch.apply(params, scene, drawn)
    names = [p.name for p in plant_scene.planes]
    model = UVMSModel(plant_params, plant_scene.water)
    current = np.asarray(sc.current.velocities[0], float) + extra
    return sc, drawn, plant_params, plant_scene, names, model, current


def _solve(nlp: dict, bounds: dict, starts: list[list[float]]) -> tuple[np.ndarray, float] | None:
    """The best of IPOPT's successful solves from `starts` (the smallest objective)."""
    solver = ca.nlpsol("s", "ipopt", nlp, {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes",
                                                                        "max_iter": 500}})
    best = None
    for z0 in starts:
        sol = solver(x0=z0, **bounds)
        if solver.stats()["success"] and (best is None or float(sol["f"]) < best[1]):
            best = (np.asarray(sol["x"]).ravel(), float(sol["f"]))
    return best


def slowest_slide(seed: int, spec: str, max_pitch: float) -> dict[str, float]:
    """Question 1 (module docstring): w [m/s] of the slowest steady slide with the tip on the wall."""
    sc, _, pp, scene, names, model, current = _setup(seed, spec)
    wall, n = scene.planes[names.index("wall")], model.n_joints
    x, pitch, w, fn = (ca.SX.sym(s) for s in ("x", "pitch", "w", "fn"))
    q, tau = ca.SX.sym("q", n), ca.SX.sym("tau", n)
    h = ca.vertcat(x, 0.0, float(sc.initial.depth), 0.0, pitch, 0.0, q,
                   euler_zyx(0.0, pitch, 0.0).T @ ca.vertcat(0.0, 0.0, w), ca.SX.zeros(3 + n))
    u = ca.vertcat(ca.SX.zeros(pp.n_thrusters), tau)
    ft = -wall.friction * fn * w / ca.sqrt(w * w + DELTA**2)
    Fw = ca.vertcat(fn, 0.0, ft, ca.SX.zeros(3))
    Q = sum(model.generalized_forces(h, u, Fw, ca.DM(obstacle_frame(wall.normal)), ca.DM(water(current)),
                                     ca.DM.zeros(3)))
    d = model.distances(h, ca.DM(wall.normal), wall.offset)
    lo_u, hi_u = pp.input_bounds()
    ql, qh = [lk.joint_range[0] for lk in pp.arm.links], [lk.joint_range[1] for lk in pp.arm.links]
    bounds = {"lbx": [-np.inf, -max_pitch, *ql, *lo_u[-n:], -1.0, 0.0],
              "ubx": [np.inf, max_pitch, *qh, *hi_u[-n:], 1.0, pp.arm.tip_force_limit],
              "lbg": [0.0] * (model.n_speeds + 1) + [0.0] * n, "ubg": [0.0] * (model.n_speeds + 1) + [np.inf] * n}
    nlp = {"x": ca.vertcat(x, pitch, q, tau, w, fn), "f": w * w, "g": ca.vertcat(Q, tip_gap(model, h, wall), d[:-1])}
    wall_x = -wall.offset / wall.normal[0]
    starts = [[wall_x - 0.8, p, *a, *([0.0] * n), -0.2, 20.0] for a in ARMS for p in PITCHES]
    best = _solve(nlp, bounds, starts)
    return {"slide_w": float("nan")} if best is None else {"slide_w": float(best[0][-2])}


def floor_strut(seed: int, spec: str, max_pitch: float) -> dict[str, float]:
    """Question 2 (module docstring): the hull's largest clearance above the seafloor [m] with the tip
    on it (NaN: no such steady state), and MuJoCo's hold of it."""
    sc, _, pp, scene, names, model, current = _setup(seed, spec)
    wi, fi = names.index("wall"), names.index("seafloor")
    wall, floor, n = scene.planes[wi], scene.planes[fi], model.n_joints
    x, z, pitch = (ca.SX.sym(s) for s in ("x", "z", "pitch"))
    q, tau, F = ca.SX.sym("q", n), ca.SX.sym("tau", n), ca.SX.sym("F", 3)
    h = ca.vertcat(x, 0.0, z, 0.0, pitch, 0.0, q, ca.SX.zeros(6 + n))
    u = ca.vertcat(ca.SX.zeros(pp.n_thrusters), tau)
    Q = sum(model.generalized_forces(h, u, ca.vertcat(F, ca.SX.zeros(3)), ca.DM(obstacle_frame(floor.normal)),
                                     ca.DM(water(current)), ca.DM.zeros(3)))
    df, dw = model.distances(h, ca.DM(floor.normal), floor.offset), model.distances(h, ca.DM(wall.normal), wall.offset)
    mu = floor.friction
    g = ca.vertcat(Q, tip_gap(model, h, floor), df[1:-1], dw, tip_gap(model, h, wall),
                   (mu * F[0]) ** 2 - F[1] ** 2 - F[2] ** 2)
    n_ineq = (n - 1) + (n + 1) + 1 + 1
    lo_u, hi_u = pp.input_bounds()
    ql, qh = [lk.joint_range[0] for lk in pp.arm.links], [lk.joint_range[1] for lk in pp.arm.links]
    bounds = {"lbx": [-np.inf, -np.inf, -max_pitch, *ql, *lo_u[-n:], 0.0, -np.inf, -np.inf],
              "ubx": [np.inf, np.inf, max_pitch, *qh, *hi_u[-n:], pp.arm.tip_force_limit, np.inf, np.inf],
              "lbg": [0.0] * (model.n_speeds + 1) + [0.0] * n_ineq,
              "ubg": [0.0] * (model.n_speeds + 1) + [np.inf] * n_ineq}
    z_floor = -floor.offset / floor.normal[2]
    wall_x = -wall.offset / wall.normal[0]
    nlp = {"x": ca.vertcat(x, z, pitch, q, tau, F), "f": -df[0], "g": g}
    starts = [[wall_x - 0.6, z_floor + 0.35, p, *a, *([0.0] * n), 20.0, 0.0, 0.0] for a in ARMS for p in PITCHES]
    best = _solve(nlp, bounds, starts)
    if best is None:
        return {"floor_clearance": float("nan")}
    zs = best[0]
    hs = np.asarray(ca.Function("h", [nlp["x"]], [h])(zs)).ravel()
    held = held_in_mujoco(sc, spec, seed, hs, zs[3 + n:3 + 2 * n], fi)
    return {"floor_clearance": -best[1], "floor_pitch_deg": float(np.degrees(zs[2])), "floor_fn": float(zs[-3]),
            "floor_joints": zs[3:3 + n].round(2).tolist()} | held


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mismatch", default="wide")
    ap.add_argument("--seeds", default="8368-8397")
    ap.add_argument("--max-pitch", type=float, default=30.0, help="deg")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    spec, max_pitch = mismatch.resolve(args.mismatch), np.radians(args.max_pitch)
    sc = get(SCENARIO)
    settings = {"mismatch": spec, "seeds": args.seeds, "max_pitch_deg": args.max_pitch, "scenario": SCENARIO}
    with manifest.recorded(args.out.with_suffix(".manifest.json"), settings), args.out.open("w") as fh:
        fh.write("seed,mass,current_x,friction,slide_w_m_s,floor_s_at_slide,floor_clearance_m,floor_pitch_deg,"
                 "floor_fn_N,floor_joints_rad,mujoco_floor_distance_change_m,mujoco_pitch_change_deg,"
                 "mujoco_hull_touched\n")
        for s in tqdm(seeds(args.seeds), unit="draw"):
            drawn = mismatch.draw(spec, s)
            _, _, _, scene, names, model, current = _setup(s, spec)
            floor = scene.planes[names.index("seafloor")]
            h0 = np.zeros(model.n_states)
            h0[2] = float(sc.initial.depth)
            start = float(np.asarray(model.distances(h0, floor.normal, floor.offset)).ravel()[0])
            a, b = slowest_slide(s, spec, max_pitch), floor_strut(s, spec, max_pitch)
            t_floor = start / abs(a["slide_w"]) if abs(a["slide_w"]) > 1e-6 else float("inf")
            fh.write(f"{s},{drawn.get('mass', 1.0):.3f},{current[0]:.3f},{floor.friction:.2f},{a['slide_w']:.3f},"
                     f"{t_floor:.1f},{b['floor_clearance']:.3f},{b.get('floor_pitch_deg', float('nan')):.1f},"
                     f"{b.get('floor_fn', float('nan')):.1f},{' '.join(map(str, b.get('floor_joints', [])))},"
                     f"{b.get('mj_distance_change', float('nan')):.4f},"
                     f"{b.get('mj_pitch_change_deg', float('nan')):.2f},"
                     f"{b.get('mj_hull_touched', '')}\n")
            fh.flush()


if __name__ == "__main__":
    main()
