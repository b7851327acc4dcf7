"""Which plane each hull contact of a campaign was on, beside the run's mismatch draw.

PYTHONPATH=. python experiments/weight_observer/contacts.py CAMPAIGN_FOLDER [SCENARIO]

Reads every run's summary.json (the campaign's `runs/`, not committed) and prints, per run whose
hull touched, the planes it touched (the hull's smallest distance to each below 0) and the drawn
hull mass factor, extra current along world x (towards the wall when positive) and wall friction.
"""

from __future__ import annotations

import sys
from pathlib import Path

from validation import results
from validation.summary import Summary


def main(folder: Path, scenario: str | None = None) -> None:
    rows = [r for r in results.read_rows(folder) if scenario in (None, r["scenario"])]
    touched: dict[str, int] = {}
    for r in sorted(rows, key=results.key):
        s = Summary.read(results.summary_path(folder, results.key(r)))
        planes = [p for p, d in s.min_distance["hull_geom"].items() if d < 0]
        if not planes:
            continue
        for p in planes:
            touched[p] = touched.get(p, 0) + 1
        v = s.mismatch["values"]
        print(f"{r['scenario']:15} {r['controller']:20} {r['seed']:>5}  hull on {'+'.join(planes):14} "
              f"mass x{v.get('mass', 1.0):.3f}  current {v.get('current', 0.0):+.3f} m/s  "
              f"friction {v.get('friction_coefficient', float('nan')):.2f}  ({s.hull_contact_impulse:.1f} N s)")
    print("hull contacts per plane:", touched)


if __name__ == "__main__":
    main(Path(sys.argv[1]), *sys.argv[2:3])
