"""Campaigns: many closed-loop runs in worker processes, with a progress bar, collected into a
results table (CSV and markdown, with 95% Wilson intervals per scenario and controller, and the
exact McNemar test of each pair of controllers on the same runs) and a manifest. A run that raises
is recorded as that run's failure (verdict "error" and the exception's first line); it never stops
the others."""

from __future__ import annotations

import csv
import multiprocessing
import statistics
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path

from tqdm import tqdm

from validation import manifest
from validation.scenarios import Scenario
from validation.statistics import paired, wilson

FIELDS = ("scenario", "controller", "seed", "verdict", "modes", "min_hull_distance", "hull_contact_impulse",
          "ee_peak_contact_force", "link_contact_impulse", "max_total_thrust_along_wall_normal",
          "final_task_error", "fallbacks", "switches", "wall_clock_s", "step_p95_I_ms", "step_p95_II_ms",
          "step_p95_III_ms", "latency", "reason")
MODES = ("I", "II", "III")


@dataclass(frozen=True)
class Job:
    scenario: Scenario
    controller: str
    mismatch: str
    seed: int
    latency: str = "none"
    ctl: tuple[tuple[str, str], ...] = ()  # dotted controller overrides


def run_job(job: Job) -> dict:
    """One run's row of the results table; exceptions become the row's verdict."""
    row = {"scenario": job.scenario.name, "controller": job.controller, "seed": job.seed, "latency": job.latency}
    try:
        from validation.closed_loop import run
        s = run(job.scenario, controller=job.controller, ctl=dict(job.ctl), mismatch=job.mismatch, seed=job.seed,
                latency=job.latency).to_dict()
        row.update({k: s[k] for k in FIELDS if k in s and k not in row})
        row["modes"] = " > ".join(s["modes"])
        row.update({f"step_p95_{m}_ms": 1e3 * s["solve_time"][m]["p95_s"] for m in MODES if m in s["solve_time"]})
    except Exception as e:  # a failed run is recorded, never fatal to the campaign
        row.update(verdict="error", reason=f"{type(e).__name__}: {e}".splitlines()[0])
    return row


def campaign(scenarios: Sequence[Scenario], controllers: Sequence[str], workers: int, out: Path,
             mismatch: str = "", seeds: int = 1, first_seed: int = 0, latency: str = "none",
             ctl: dict[str, str] | None = None) -> list[dict]:
    """Run every scenario with every controller and every seed first_seed..first_seed+seeds-1 of the
    mismatch (the same draws for every controller), with the computation delay `latency`
    (validation.closed_loop.parse_latency); write out/results.csv and out/results.md."""
    from validation.closed_loop import parse_latency

    parse_latency(latency)  # a bad spec fails here, in one line, not in every run
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"output path {out}: {e.strerror}; allowed: a writable folder") from None
    overrides = tuple(sorted((ctl or {}).items()))
    jobs = [Job(s, c, mismatch, seed, latency, overrides) for s in scenarios
            for seed in range(first_seed, first_seed + seeds) for c in controllers]
    rows, started, origin = [], time.perf_counter(), manifest.start()
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=max(1, workers), mp_context=ctx) as pool:
        futures = [pool.submit(run_job, j) for j in jobs]
        for f in tqdm(as_completed(futures), total=len(futures), desc="campaign", unit="run"):
            rows.append(f.result())
    order = {(j.scenario.name, j.controller, j.seed): i for i, j in enumerate(jobs)}
    rows.sort(key=lambda r: order[(r["scenario"], r["controller"], r["seed"])])
    with (out / "results.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=FIELDS)
        writer.writeheader()
        for r in rows:
            writer.writerow({k: r.get(k, "") for k in FIELDS})
    (out / "results.md").write_text(markdown(rows))
    settings = {"scenarios": [{"name": sc.name, **sc.to_data()} for sc in scenarios], "controllers": {},
                "ctl": ctl or {}, "mismatch": mismatch, "seeds": list(range(first_seed, first_seed + seeds)),
                "latency": latency, "workers": workers}
    from validation import presets
    for c in controllers:
        try:
            r = presets.resolve(c, ctl)
            settings["controllers"][c] = {"class": f"{r.cls.__module__}:{r.cls.__qualname__}",
                                          "overrides": r.overrides, "settings": r.settings_dict()}
        except ValueError as e:
            settings["controllers"][c] = {"error": str(e)}
    manifest.write(out, settings, time.perf_counter() - started, started=origin)
    return rows


def _fmt(v) -> str:
    return f"{v:.3f}" if isinstance(v, float) else str(v)


def markdown(rows: list[dict]) -> str:
    cols = ("scenario", "controller", "seed", "verdict", "modes", "min_hull_distance", "hull_contact_impulse",
            "ee_peak_contact_force", "link_contact_impulse", "fallbacks", "switches")
    delays = sorted({str(r.get("latency", "none")) for r in rows} - {"none"})
    lines = [f"Computation delay: {', '.join(delays)} (validation.closed_loop: the plant does not wait for the "
             "controller).", ""] if delays else []
    lines += ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(_fmt(r.get(c, "")) for c in cols) + " |" for r in rows]
    controllers = list(dict.fromkeys(r["controller"] for r in rows))
    families = list(dict.fromkeys(r["scenario"] for r in rows))

    def rate(sel: list[dict]) -> str:
        k, n = sum(r.get("verdict") == "success" for r in sel), len(sel)
        lo, hi = wilson(k, n)
        return f"{k}/{n} ({100 * lo:.0f}-{100 * hi:.0f}%)"

    lines += ["", "Success (only the end-effector tip touched: zero contact impulse on the hull and on every "
              "other arm link, and the tip's peak force within the jaws' limit) per scenario family, with the "
              "95% Wilson interval of the rate:", "",
              "| scenario | " + " | ".join(controllers) + " |", "|" + "---|" * (len(controllers) + 1)]
    lines += [f"| {f} | " + " | ".join(rate([r for r in rows if r["scenario"] == f and r["controller"] == c])
                                       for c in controllers) + " |" for f in families]
    lines += ["| all | " + " | ".join(rate([r for r in rows if r["controller"] == c]) for c in controllers) + " |"]

    if len(controllers) > 1:
        lines += ["", "Paired on the same runs (scenario, seed): both succeed / only the first / only the second / "
                  "neither, and the exact McNemar test:", ""]
        for a, b in combinations(controllers, 2):
            pa, pb = ({(r["scenario"], r["seed"]): r.get("verdict") == "success" for r in rows if r["controller"] == c}
                      for c in (a, b))
            p = paired(pa, pb)
            lines.append(f"- {a} vs {b}: {p.both} / {p.only_a} / {p.only_b} / {p.neither}; {p.reading(a, b)}")

    def p95(c: str, m: str) -> str:
        ms = [float(r[f"step_p95_{m}_ms"]) for r in rows if r["controller"] == c and r.get(f"step_p95_{m}_ms") not in
              (None, "")]
        return f"{statistics.median(ms):.0f} ({max(ms):.0f})" if ms else "-"

    lines += ["", "Whole-step time per mode (certificate, guesses, solve), each run's p95 [ms]: the median over the "
              "runs (the largest):", "", "| mode | " + " | ".join(controllers) + " |",
              "|" + "---|" * (len(controllers) + 1)]
    lines += [f"| {m} | " + " | ".join(p95(c, m) for c in controllers) + " |" for m in MODES]
    return "\n".join(lines) + "\n"
