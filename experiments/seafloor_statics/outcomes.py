"""The closed loop's verdicts beside each draw's statics: `outcomes.md`.

PYTHONPATH=. python experiments/seafloor_statics/outcomes.py STATICS.csv CAMPAIGN/results.csv > outcomes.md

A floor strut is "held" when MuJoCo's 2 s hold moves the hull less than 5 cm towards the seafloor
and the hull touches nothing. The wall "keeps the hull up" for the scenario's time when the slowest
steady slide rises (a light hull) or needs longer than the scenario's duration to reach the seafloor.
"""

from __future__ import annotations

import csv
import sys

from validation.scenarios import get

HELD = -0.05  # m: the largest sink towards the seafloor in MuJoCo's hold that counts as held


def plane(reason: str) -> str:
    """'seafloor', 'wall', 'wall and seafloor' or '' from a hull-contact reason."""
    if not reason.startswith("the hull touched the "):
        return ""
    return reason.removeprefix("the hull touched the ").split(" with ")[0].replace(" and the ", " and ")


def main() -> None:
    statics = {r["seed"]: r for r in csv.DictReader(open(sys.argv[1]))}
    runs = {r["seed"]: r for r in csv.DictReader(open(sys.argv[2]))}
    duration = get("thrusters-dead").duration
    print("| seed | mass x | current [m/s] | mu | verdict | slowest slide [m/s] | to the seafloor [s] | "
          "floor strut: hull up [m] | held in MuJoCo |")
    print("|---|---|---|---|---|---|---|---|---|")
    tally: dict[str, list[int]] = {}
    for seed in sorted(runs, key=int):
        s, r = statics[seed], runs[seed]
        where = plane(r["reason"])
        verdict = r["verdict"] + (f" ({where})" if where else "")
        strut = s["floor_clearance_m"] != "nan"
        held = strut and s["mujoco_hull_touched"] == "False" and float(s["mujoco_floor_distance_change_m"]) >= HELD
        rising = float(s["slide_w_m_s"]) >= 0.0
        slow = rising or float(s["floor_s_at_slide"]) > duration
        print(f"| {seed} | {s['mass']} | {s['current_x']} | {s['friction']} | {verdict} | {s['slide_w_m_s']} | "
              f"{'never' if rising else s['floor_s_at_slide']} | {s['floor_clearance_m'] if strut else 'none'} | "
              f"{('yes' if held else 'no') if strut else ''} |")
        key = where or r["verdict"]
        tally.setdefault(key, [0, 0, 0, 0])
        tally[key] = [a + b for a, b in zip(tally[key], [1, slow, strut, held], strict=True)]
    print()
    print(f"| outcome | runs | wall keeps the hull up for {duration:g} s | a floor strut exists | MuJoCo holds it |")
    print("|---|---|---|---|---|")
    for key, (n, slow, strut, held) in sorted(tally.items()):
        print(f"| {key} | {n} | {slow} | {strut} | {held} |")


if __name__ == "__main__":
    main()
