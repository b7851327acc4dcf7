"""Closed-loop real-time factor (simulated seconds per wall-clock second) of wall-headon in MuJoCo,
with and without a Rerun recording, side by side in one run, and the controller's whole-step
times per mode; also with Mode I's real-time iteration ("switching-rti").
Run: `python bench/closed_loop_rtf.py`; writes bench/results/closed_loop_rtf.json and .md.
"""

from __future__ import annotations

import json
import platform
import tempfile
from dataclasses import replace
from pathlib import Path

from validation.closed_loop import run
from validation.scenarios import get

OUT = Path(__file__).parent / "results"
DURATION = 3.0  # s simulated
SEED = 1  # the demo's draw of the default mismatch


def main() -> None:
    sc = replace(get("wall-headon"), duration=DURATION)
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, record, controller in (("without recording", None, "switching"),
                                         ("with recording", Path(tmp) / "run.rrd", "switching"),
                                         ("switching-rti, without recording", None, "switching-rti")):
            s = run(sc, record=record, seed=SEED, controller=controller)
            rows[name] = {"simulated_s": s.simulated_s, "wall_clock_s": s.wall_clock_s,
                          "real_time_factor": s.simulated_s / s.wall_clock_s, "modes": s.modes, "steps": len(s.steps),
                          "step_ms": {m: [1e3 * t.median_s, 1e3 * t.p95_s] for m, t in s.solve_time.items()}}
    OUT.mkdir(exist_ok=True)
    (OUT / "closed_loop_rtf.json").write_text(json.dumps({"machine": platform.machine(), "rows": rows}, indent=2))
    lines = [f"# Closed-loop real-time factor, wall-headon in MuJoCo ({platform.machine()}, 2 cores)", "",
             f"`python bench/closed_loop_rtf.py`: {DURATION} s simulated, default mismatch seed {SEED}.", "",
             "| variant | simulated [s] | wall clock [s] | real-time factor | steps | modes | "
             "step time median / p95 [ms] per mode |",
             "|---|---|---|---|---|---|---|"]
    for k, r in rows.items():
        per_mode = ", ".join(f"{m}: {a:.0f} / {b:.0f}" for m, (a, b) in r["step_ms"].items())
        lines.append(f"| {k} | {r['simulated_s']:.1f} | {r['wall_clock_s']:.1f} | {r['real_time_factor']:.3f} | "
                     f"{r['steps']} | {' > '.join(r['modes'])} | {per_mode} |")
    (OUT / "closed_loop_rtf.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    from validation import manifest

    with manifest.recorded(Path(__file__).parent / "results" / "closed_loop_rtf.manifest.json"):
        main()
