"""Campaign throughput and memory: runs per minute and the per-run engine overhead of the local pool
with 1 and 2 workers and of a Dask LocalCluster with 2 workers, side by side in one run (rounds
interleaved, medians quoted); and the peak memory of the campaign process at 20 and at 200 short runs.

Two workloads: "short" (avoid-wall, 0.3 s simulated, the braking baseline and the PD example: the
run itself takes milliseconds, so the time is the engine's) and "switching" (wall-headon, 5 s
simulated, the switching NMPC: a real run). The per-run overhead is (wall time x slots - the runs'
own wall time) / runs: process start, imports, the controller's construction, scheduling, result
I/O, and the campaign's start and end (Dask: starting the cluster).

Run: `python bench/campaign_throughput.py` (compiled code cached first: `uvms build --scenarios
avoid-wall,wall-headon`); writes bench/results/campaign_throughput.json and .md.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from validation import precompile
from validation.campaign import campaign
from validation.mismatch import DEFAULT
from validation.scenarios import get

OUT = Path(__file__).parent / "results"
PD = "examples.pd_station_keeper:PDStationKeeper"
ENGINES = {"local pool, 1 worker": (1, None), "local pool, 2 workers": (2, None),
           "Dask LocalCluster, 2 workers": (2, "local:2")}
WORKLOADS = {"short": ([replace(get("avoid-wall"), duration=0.3)], ["braking", PD], 20),  # 40 runs
             "switching": ([get("wall-headon")], ["switching"], 8)}  # 8 runs
MEMORY_RUNS = (20, 200)


def _one(workload: str, workers: int, cluster: str | None, folder: Path) -> dict:
    scenarios, controllers, seeds = WORKLOADS[workload]
    t0 = time.perf_counter()
    rows = campaign(scenarios, controllers, workers, folder, DEFAULT, seeds, cluster=cluster, quiet=True)
    wall = time.perf_counter() - t0
    own = sum(float(r["wall_clock_s"]) for r in rows)
    return {"runs": len(rows), "wall_s": wall, "runs_per_min": 60 * len(rows) / wall,
            "overhead_per_run_s": (wall * workers - own) / len(rows), "run_s_median": statistics.median(
                float(r["wall_clock_s"]) for r in rows), "failed": sum(r["verdict"] in ("error", "timeout",
                                                                                        "worker died") for r in rows)}


def _peak_memory(runs: int, cluster: str | None) -> float:
    """The campaign process's peak resident memory [MB] for `runs` short runs (a fresh process)."""
    extra = ["--cluster", cluster] if cluster else []
    out = subprocess.run([sys.executable, __file__, "--memory", str(runs), *extra], capture_output=True, text=True,
                         check=True)
    return float(out.stdout.strip().splitlines()[-1])


def _memory_child(runs: int, cluster: str | None) -> None:
    scenarios, controllers, _ = WORKLOADS["short"]
    with tempfile.TemporaryDirectory() as tmp:
        campaign(scenarios, controllers, 2, Path(tmp), DEFAULT, runs // len(controllers), cluster=cluster, quiet=True)
    print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)  # kB on Linux


def main(rounds: int) -> None:
    for scenarios, controllers, _ in WORKLOADS.values():
        precompile.build(scenarios, controllers)
    raw: dict[str, dict[str, list[dict]]] = {w: {e: [] for e in ENGINES} for w in WORKLOADS}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(rounds):
            for w in WORKLOADS:
                for i, (name, (workers, cluster)) in enumerate(ENGINES.items()):
                    raw[w][name].append(_one(w, workers, cluster, Path(tmp) / f"{w}-{i}-{k}"))
                    print(w, name, raw[w][name][-1], flush=True)
    memory = {f"{n} runs, {e}": _peak_memory(n, c) for n in MEMORY_RUNS
              for e, c in (("local pool, 2 workers", None), ("Dask LocalCluster, 2 workers", "local:2"))}
    med = {w: {e: {k: statistics.median(r[k] for r in rs) for k in rs[0]} for e, rs in per.items()}
           for w, per in raw.items()}
    OUT.mkdir(exist_ok=True)
    (OUT / "campaign_throughput.json").write_text(json.dumps({"rounds": rounds, "raw": raw, "median": med,
                                                              "peak_memory_mb": memory}, indent=1))
    lines = ["# Campaign throughput and memory", "",
             f"`python bench/campaign_throughput.py --rounds {rounds}`: medians of {rounds} interleaved rounds; "
             "default mismatch; each run in a worker's child process (validation.isolated).", "",
             "| workload | engine | runs | wall [s] | runs / min | run's own time, median [s] | "
             "engine overhead per run [s] | failed |", "|---|---|---|---|---|---|---|---|"]
    for w, per in med.items():
        for e, m in per.items():
            lines.append(f"| {w} | {e} | {m['runs']:.0f} | {m['wall_s']:.1f} | {m['runs_per_min']:.1f} | "
                         f"{m['run_s_median']:.2f} | {m['overhead_per_run_s']:.2f} | {m['failed']:.0f} |")
    lines += ["", "Peak resident memory of the campaign process (its run processes and Dask workers not counted), "
              "short runs:", "", "| campaign | peak memory [MB] |", "|---|---|"]
    lines += [f"| {k} | {v:.0f} |" for k, v in memory.items()]
    (OUT / "campaign_throughput.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--memory", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--cluster", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.memory:
        _memory_child(args.memory, args.cluster)
    else:
        from validation import manifest

        with manifest.recorded(OUT / "campaign_throughput.manifest.json", {"rounds": args.rounds,
                                                                           "engines": ENGINES,
                                                                           "memory_runs": MEMORY_RUNS}):
            main(args.rounds)
