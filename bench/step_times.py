"""Whole-step computation time per mode in MuJoCo closed loops, controller variants side by side.

A step's time is the closed loop's wall-clock timing of the controller's step() (certificate,
guesses, solve, fallbacks: what a real-time loop must wait for). Each variant (dotted overrides of
the default preset) flies the same runs, one run at a time, the variants interleaved run by run so
that the machine's drifts fall on all of them alike; by default the plant waits for the controller
(no latency), so every variant sees the states its own decisions lead to.

  python bench/step_times.py              # development seeds 0-1 of four families (about 5 min)
  python bench/step_times.py --seeds 3
  python bench/step_times.py --latency 0.05:strict --variants default,without --name step_times_strict
                                          # strict real time at 50 ms (the helper process runs)

Writes bench/results/NAME.md (default step_times) and its manifest: per variant and mode, the steps,
and the whole-step median, p95, p99 and max [ms], and the share of steps over 20, 50 and 100 ms.
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

OUT = Path(__file__).parent / "results"
FAMILIES = ("wall-headon", "wall-oblique", "arm-deployed", "thrusters-dead")
MODES = ("I", "II", "III")
BUDGETS = (0.02, 0.05, 0.1)  # s
# name: dotted overrides of the default preset
VARIANTS: dict[str, dict] = {
    "default": {},
    "the paper's model (without the joints' damping)": {"model_joint_damping": "false"},
    # the same as the default without a latency on the wall clock (the helper runs only there)
    "without Mode III's next step solved ahead": {"mode3_step_helper": "false"},
}


def measure(seeds: int, variants: list[str], latency: str = "none") -> dict[str, dict[str, list[float]]]:
    """Per variant and mode, every step's time [s] over the runs."""
    from validation.closed_loop import run
    from validation.scenarios import get

    times: dict[str, dict[str, list[float]]] = {v: {m: [] for m in MODES} for v in variants}
    jobs = [(f, s, v) for f in FAMILIES for s in range(seeds) for v in variants]
    for family, seed, variant in tqdm(jobs, desc="closed loops", unit="run"):
        summary = run(get(family), seed=seed, ctl=VARIANTS[variant], latency=latency)
        for st in summary.steps:
            times[variant][st.mode].append(st.compute_time)
    return times


def table(times: dict[str, dict[str, list[float]]], seeds: int, command: str, latency: str) -> str:
    delay = "no latency" if latency == "none" else f"latency {latency}"
    lines = ["# Whole-step time per mode, variants side by side", "",
             f"`{command}` ({platform.machine()}, casadi {ca.__version__}, one run at "
             f"a time): {', '.join(FAMILIES)}, development seeds 0-{seeds - 1}, default mismatch, {delay}; the "
             "variants interleaved run by run. Times: the closed loop's wall clock of each step() [ms].", "",
             "| variant | mode | steps | median | p95 | p99 | max | "
             + " | ".join(f"> {1e3 * b:.0f} ms" for b in BUDGETS) + " |",
             "|---|---|---|---|---|---|---|" + "---|" * len(BUDGETS)]
    for variant, per_mode in times.items():
        for mode in MODES:
            t = 1e3 * np.asarray(per_mode[mode])
            if not len(t):
                continue
            over = " | ".join(f"{100 * np.mean(t > 1e3 * b):.0f} %" for b in BUDGETS)
            lines.append(f"| {variant} | {mode} | {len(t)} | {np.median(t):.0f} | {np.percentile(t, 95):.0f} | "
                         f"{np.percentile(t, 99):.0f} | {t.max():.0f} | {over} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2, help="seeds 0..SEEDS-1 per family")
    ap.add_argument("--latency", default="none", help="the closed loop's --latency (e.g. 0.05:strict)")
    ap.add_argument("--variants", default="", help="comma-separated prefixes of the variants (default: all)")
    ap.add_argument("--name", default="step_times", help="the result's file stem in bench/results")
    a = ap.parse_args(argv)
    if a.seeds < 1:
        raise SystemExit(f"--seeds {a.seeds}; allowed: >= 1")
    prefixes = [p for p in a.variants.split(",") if p] or [""]
    chosen = [v for v in VARIANTS if any(v.startswith(p) for p in prefixes)]
    unknown = [p for p in prefixes if not any(v.startswith(p) for v in VARIANTS)]
    if unknown:
        raise SystemExit(f"--variants {unknown}; allowed: prefixes of {list(VARIANTS)}")
    command = "python bench/step_times.py " + " ".join(argv or [])
    text = table(measure(a.seeds, chosen, a.latency), a.seeds, command.strip(), a.latency)
    (OUT / f"{a.name}.md").write_text(text)
    print(text)


if __name__ == "__main__":
    from validation import manifest

    name = next((sys.argv[i + 1] for i, x in enumerate(sys.argv[:-1]) if x == "--name"), "step_times")
    with manifest.recorded(OUT / f"{name}.manifest.json", {"variants": VARIANTS, "families": FAMILIES}):
        main(sys.argv[1:])
