"""The best steady state a vehicle with every thruster dead can reach with its tip on the wall.

PYTHONPATH=. python experiments/thrusters_dead_statics/statics.py --out FILE.csv [--mismatch wide]
    [--seeds 7100-7129,7200-7229] [--max-pitch DEG]    (writes FILE.csv and FILE.manifest.json)

For each mismatch draw of thrusters-dead, the plant's own parameters (validation.mismatch.apply:
mass, drag, added mass, centre of buoyancy, wall friction, the scenario's current plus the drawn
one) go into the controller's Kane model, and IPOPT finds the steady state that keeps the hull
furthest from the wall: the vehicle at rest or sliding along the wall at a constant vertical speed w,
no rotation, the tip on the wall pushing with F_n <= the jaws' limit and its friction
F_t = -mu F_n w / sqrt(w^2 + delta^2) (Mode III's smooth law), the joints' torques within their
limits, the other links off the wall; zero acceleration: the model's generalized forces balance.
Unknowns: the hull's x and pitch, the joint angles and torques, w, F_n. Several starts; the best
is kept. A negative clearance means that no steady strut keeps the hull off the wall.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

from controller.kinematics import euler_zyx
from controller.mode3 import ModeIIISettings
from controller.model import UVMSModel, water
from controller.transcription import obstacle_frame, tip_gap
from uvms import load_params
from validation import manifest, mismatch
from validation.scenarios import Scenario, get
from validation.setup import build_plant, scene_of

DELTA = ModeIIISettings().friction_smoothing  # m/s, Mode III's friction smoothing
HOLD = 2.0  # s, the MuJoCo check's hold
STARTS = [(q, pitch) for q in ([0.0, 1.0, 0.5, 0.0], [0.0, 0.3, 0.3, 0.0], [0.0, -0.5, 0.5, 0.0], [0.0, 1.6, 1.5, 0.0])
          for pitch in (0.0, 0.3, -0.3, 0.6, -0.6)]


def best_strut(seed: int, spec: str, max_pitch: float = 1.4, scenario: str = "thrusters-dead") -> dict[str, float]:
    """The steady state of the draw `seed` of `spec` with the largest hull clearance, |pitch| <= max_pitch [rad]."""
    sc = get(scenario)
    params, scene = load_params(arm=sc.arm), scene_of(sc)
    drawn = mismatch.draw(spec, seed)
    plant_params, plant_scene, extra, _ = mismatch.apply(params, scene, drawn)
    wall_i = [p.name for p in plant_scene.planes].index("wall")
    wall = plant_scene.planes[wall_i]
    model = UVMSModel(plant_params, plant_scene.water)
    n = model.n_joints
    current = np.asarray(sc.current.velocities[0], float) + extra
    z0 = float(sc.initial.depth)
    x, pitch, w, fn = (ca.SX.sym(s) for s in ("x", "pitch", "w", "fn"))
    q, tau = ca.SX.sym("q", n), ca.SX.sym("tau", n)
    R = euler_zyx(0.0, pitch, 0.0)
    v_body = R.T @ ca.vertcat(0.0, 0.0, w)
    h = ca.vertcat(x, 0.0, z0, 0.0, pitch, 0.0, q, v_body, ca.SX.zeros(3 + n))
    u = ca.vertcat(ca.SX.zeros(plant_params.n_thrusters), tau)
    Rw = obstacle_frame(wall.normal)
    if abs(Rw[2, 2]) < 0.99:
        raise ValueError(f"{scenario}: the wall is not vertical; allowed: a vertical wall (the slide is along z)")
    ft = -wall.friction * fn * w / ca.sqrt(w * w + DELTA**2)  # along the obstacle frame's vertical tangent
    Fw = ca.vertcat(fn, 0.0, ft, ca.SX.zeros(3))
    Q = sum(model.generalized_forces(h, u, Fw, ca.DM(Rw), ca.DM(water(current)), ca.DM.zeros(3)))
    d = model.distances(h, ca.DM(wall.normal), wall.offset)
    hull = d[0]
    g = ca.vertcat(Q, tip_gap(model, h, wall), d[1:-1])
    z = ca.vertcat(x, pitch, q, tau, w, fn)
    lo_u, hi_u = plant_params.input_bounds()
    q_lo = [lk.joint_range[0] for lk in plant_params.arm.links]
    q_hi = [lk.joint_range[1] for lk in plant_params.arm.links]
    lbx = [-np.inf, -max_pitch, *q_lo, *lo_u[-n:], -1.0, 0.0]
    ubx = [np.inf, max_pitch, *q_hi, *hi_u[-n:], 1.0, plant_params.arm.tip_force_limit]
    nq = model.n_speeds
    lbg = [0.0] * (nq + 1) + [0.0] * (n - 1)
    ubg = [0.0] * (nq + 1) + [np.inf] * (n - 1)
    solver = ca.nlpsol("strut", "ipopt", {"x": z, "f": -hull, "g": g},
                       {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes", "max_iter": 500}})
    wall_x = -wall.offset / wall.normal[0]
    best = None
    for q0, p0 in STARTS:
        z_init = [wall_x - 0.8, float(np.clip(p0, -max_pitch, max_pitch)), *q0, *([0.0] * n), 0.0, 20.0]
        sol = solver(x0=z_init, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        if not solver.stats()["success"]:
            continue
        zs = np.asarray(sol["x"]).ravel()
        if best is None or -float(sol["f"]) > best["clearance"]:
            best = {"clearance": -float(sol["f"]), "pitch_deg": np.degrees(zs[1]), "w": zs[-2], "fn": zs[-1],
                    "q": zs[2:2 + n].round(2).tolist(), "h": np.asarray(ca.Function("h", [z], [h])(zs)).ravel(),
                    "tau": zs[2 + n:2 + 2 * n]}
    out = {"seed": seed, "mass": drawn.get("mass", 1.0), "current": float(current[0]), "friction": wall.friction}
    if best is None:
        return out | {"clearance": float("nan")}
    return out | best | held_in_mujoco(sc, spec, seed, best["h"], best["tau"], wall_i)


def held_in_mujoco(sc: Scenario, spec: str, seed: int, h: np.ndarray, tau: np.ndarray, wall: int) -> dict[str, float]:
    """The oracle: the drawn MuJoCo plant (its own fluid forces, buoyancy and contact) started at the
    steady strut, the joints held at its angles by its torques plus a PD (20 N m/rad, 2 N m s/rad),
    every thruster dead, for HOLD seconds: how far the hull's wall distance and pitch moved, and
    whether the hull touched anything."""
    _, _, plant, _ = build_plant(sc, spec, seed)
    plant.reset(h)
    n, hull = len(tau), plant.geom_names.index("hull_geom")
    nt = plant.params.n_thrusters
    d0 = float(plant.step(np.r_[np.zeros(nt), tau], 0.01).distances[hull, wall])
    touched = False
    for _ in range(round(HOLD / 0.01)):
        x = plant.state()
        u = np.r_[np.zeros(nt), tau + 20.0 * (h[6:6 + n] - x[6:6 + n]) - 2.0 * x[12 + n:]]
        report = plant.step(u, 0.01)
        touched |= any(c.geom == "hull_geom" for c in report.contacts)
    x = plant.state()
    return {"mj_distance_change": float(report.distances[hull, wall]) - d0,
            "mj_pitch_change_deg": float(np.degrees(x[4] - h[4])), "mj_hull_touched": touched}


def seeds(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mismatch", default="wide")
    ap.add_argument("--seeds", default="7100-7129,7200-7229")
    ap.add_argument("--max-pitch", type=float, default=80.0, help="deg")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    spec = mismatch.resolve(args.mismatch)
    settings = {"mismatch": spec, "seeds": args.seeds, "max_pitch_deg": args.max_pitch, "starts": STARTS}
    with manifest.recorded(args.out.with_suffix(".manifest.json"), settings), args.out.open("w") as fh:
        fh.write("seed,mass,current_x,friction,clearance_m,pitch_deg,slide_w_m_s,tip_normal_N,joints_rad,"
                 "mujoco_distance_change_m,mujoco_pitch_change_deg,mujoco_hull_touched\n")
        for s in tqdm(seeds(args.seeds), unit="draw"):
            r = best_strut(s, spec, np.radians(args.max_pitch))
            fh.write(f"{r['seed']},{r['mass']:.3f},{r['current']:.3f},{r['friction']:.2f},{r['clearance']:.3f},"
                     f"{r.get('pitch_deg', float('nan')):.1f},{r.get('w', float('nan')):.3f},"
                     f"{r.get('fn', float('nan')):.1f},{' '.join(map(str, r.get('q', [])))},"
                     f"{r.get('mj_distance_change', float('nan')):.4f},"
                     f"{r.get('mj_pitch_change_deg', float('nan')):.2f},"
                     f"{r.get('mj_hull_touched', '')}\n")


if __name__ == "__main__":
    main()
