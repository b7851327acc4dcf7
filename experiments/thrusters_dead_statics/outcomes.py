"""The closed loops' thrusters-dead outcomes beside what MuJoCo did with each draw's steady strut.

PYTHONPATH=. python experiments/thrusters_dead_statics/outcomes.py

Reads wide_pitch15.csv and the wide campaigns' results (the default at 6f4d27b for seeds 7100-7129,
`switching-observer` there, and both controllers on 7200-7229) and counts, per controller, the hull
contacts among the draws whose strut MuJoCo moved more than DRIFT towards the wall in 2 s, held
(within DRIFT and PITCH), or moved otherwise (away from the wall, or pitched further).
"""

from __future__ import annotations

import collections
import csv
from pathlib import Path

HERE = Path(__file__).parent
EXPERIMENTS = HERE.parent
DRIFT, PITCH = 0.05, 15.0  # m, deg
CAMPAIGNS = {  # folder: {controller in its results.csv: name here}
    EXPERIMENTS / "wide_known_7100" / "head": {"switching": "switching (default)"},
    EXPERIMENTS / "weight_observer" / "wide_7100": {"switching-observer": "switching-observer"},
    EXPERIMENTS / "weight_observer" / "wide_7200" / "switching": {"switching": "switching (default)"},
    EXPERIMENTS / "weight_observer" / "wide_7200" / "observer": {"switching-observer": "switching-observer"},
}


def main() -> None:
    struts = {int(r["seed"]): r for r in csv.DictReader((HERE / "wide_pitch15.csv").open())}
    counts: collections.Counter = collections.Counter()
    for folder, names in CAMPAIGNS.items():
        for r in csv.DictReader((folder / "results.csv").open()):
            seed = int(r["seed"])
            if r["scenario"] != "thrusters-dead" or r["controller"] not in names or seed not in struts:
                continue
            s = struts[seed]
            moved, pitched = float(s["mujoco_distance_change_m"]), abs(float(s["mujoco_pitch_change_deg"]))
            kind = ("towards the wall" if moved < -DRIFT else
                    "held" if abs(moved) <= DRIFT and pitched <= PITCH else "away, or pitched")
            counts[(names[r["controller"]], kind, "draws")] += 1
            counts[(names[r["controller"]], kind, "hull contacts")] += r["verdict"] == "hull contact"
    print(f"| controller | strut in MuJoCo (2 s; {DRIFT * 100:.0f} cm, {PITCH:.0f} deg) | draws | hull contacts |")
    print("|---|---|---|---|")
    for name in dict.fromkeys(n for names in CAMPAIGNS.values() for n in names.values()):
        for kind in ("towards the wall", "held", "away, or pitched"):
            print(f"| {name} | {kind} | {counts[(name, kind, 'draws')]} | {counts[(name, kind, 'hull contacts')]} |")


if __name__ == "__main__":
    main()
