"""Plant demo: the default UVMS released at 30 deg of roll, thrusters off, arm held at home by its
joint servos. It rights itself (centre of buoyancy above the centre of gravity), pitches under the
weight of its arm and sinks slowly (it is heavier than the water it displaces).

`python -m uvms_mj.demo --out out` writes out/plant_demo.mp4 (headless, EGL) and
out/plant_demo.json (time series), and prints a short table.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import argparse
import json
from pathlib import Path

import numpy as np

from uvms import load_params, load_scene
from uvms.params import UVMSParams
from uvms_mj.plant import Plant
from uvms_mj.render import VideoRecorder

SERVO_PERIOD = 0.01  # s
SERVO_KP, SERVO_KD = 4.0, 0.4  # N m/rad, N m s/rad: a gentle joint servo holding the home posture


def hold_posture(params: UVMSParams, h: np.ndarray) -> np.ndarray:
    """u with thrusters off and joint torques from a PD servo to the home posture."""
    nj = params.n_joints
    q, qd = h[6:6 + nj], h[12 + nj:]
    tau = SERVO_KP * (params.arm.home - q) - SERVO_KD * qd
    return np.concatenate([np.zeros(params.n_thrusters), tau])


def run(out: Path, duration: float = 20.0, fps: int = 25) -> list[dict[str, float]]:
    params, scene = load_params(), load_scene()
    plant = Plant(params, scene)
    h0 = np.zeros(params.n_states)
    h0[2], h0[3] = -1.0, np.radians(30.0)
    h0[6:6 + params.n_joints] = params.arm.home
    plant.reset(h0)
    rows = []
    servo_steps = round(1.0 / (fps * SERVO_PERIOD))
    with VideoRecorder(plant, out / "plant_demo.mp4", fps=fps) as video:
        for frame in range(round(duration * fps) + 1):
            video.capture()
            h = plant.state()
            if frame % fps == 0:
                rows.append({"t": round(plant.t, 3), "x": h[0], "z": h[2], "roll_deg": np.degrees(h[3]),
                             "pitch_deg": np.degrees(h[4]), "vz": h[8]})
            for _ in range(servo_steps):
                plant.step(hold_posture(params, plant.state()), SERVO_PERIOD)
    (out / "plant_demo.json").write_text(json.dumps(rows, indent=1))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("out"), help="output folder")
    ap.add_argument("--duration", type=float, default=20.0, help="simulated seconds")
    args = ap.parse_args()
    rows = run(args.out, args.duration)
    print(f"{'t [s]':>6} {'x [m]':>7} {'z [m]':>7} {'roll [deg]':>10} {'pitch [deg]':>11}")
    for r in rows[::2]:
        print(f"{r['t']:6.1f} {r['x']:7.3f} {r['z']:7.3f} {r['roll_deg']:10.2f} {r['pitch_deg']:11.2f}")
    print(f"wrote {args.out / 'plant_demo.mp4'} and {args.out / 'plant_demo.json'}")


if __name__ == "__main__":
    main()
