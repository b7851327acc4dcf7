"""Peak joint rates [rad/s] in Mode II plans and in the plant during Mode II, on development seeds of the wall
families: [CTL=key=value,...] python jointspeed.py LATENCY SEED..."""

import os
import sys

import numpy as np

from controller import switching
from validation import presets
from validation.closed_loop import run
from validation.scenarios import SCENARIOS

step = switching.SwitchingNMPC.step
REC: dict[str, list[np.ndarray]] = {"plan": [], "meas": []}


def traced(self, h, t, ahead=None):
    u, info = step(self, h, t, ahead)
    n = self.model.n_joints
    if info.mode.value == "II":
        REC["meas"].append(np.abs(h[-n:]))
        if info.h_pred is not None:
            REC["plan"].append(np.abs(np.asarray(info.h_pred)[:, -n:]).max(axis=0))
    return u, info


def peaks(key: str) -> str:
    return str(np.round(np.max(REC[key], axis=0), 1)) if REC[key] else "-"


switching.SwitchingNMPC.step = traced
ctl = dict(kv.split("=") for kv in os.environ.get("CTL", "").split(",") if kv)
latency = sys.argv[1]
for family in ("wall-headon", "wall-oblique", "arm-deployed"):
    for seed in map(int, sys.argv[2:]):
        REC["plan"].clear()
        REC["meas"].clear()
        s = run(SCENARIOS[family], seed=seed, latency=latency,
                controller=switching.SwitchingController(presets.resolve("switching", ctl).settings))
        print(family, seed, s.verdict, "plan peak", peaks("plan"), "plant peak", peaks("meas"), flush=True)
