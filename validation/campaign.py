"""Campaigns: every scenario with every controller and seed, each run in a child process apart from the
campaign's (validation.isolated: one child per worker thread, replaced after a crash, a timeout or 25
runs), on this machine's cores or on a Dask cluster, with a progress bar.

Each finished run is written at once (validation.results: its summary.json, then its row of
results.csv, synced), so a killed campaign keeps what it did and `resume=True` runs only what is
missing. A run that raises is recorded as verdict "error" with the exception's first line; a run
past `timeout` seconds is stopped and recorded as "timeout"; a run whose process dies (a segfault,
the OOM killer) is recorded as "worker died" with the cause. None of them stops the others. At the
end: results.md (every row, the rates per family and controller with 95% Wilson intervals, the
exact McNemar test of each pair of controllers), success.png and manifest.json.

Engines. Without `cluster`, `workers` threads of this process each supervise one run's process.
With `cluster` (a Dask scheduler's address, e.g. tcp://host:8786, or "local:N" for a Dask
LocalCluster of N workers on this machine), the runs are Dask tasks: a worker receives the job as
plain data (scenario, controller name, overrides, mismatch, seed) and starts the run's process
itself, so nothing CasADi or MuJoCo crosses the wire. Before the runs, each host compiles what they
need once into its own cache (validation.precompile, one worker a host).
"""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from validation import isolated, manifest, report, results
from validation.scenarios import Scenario

MODES = report.MODES


@dataclass(frozen=True)
class Job:
    """One run, as plain data."""

    scenario: Scenario
    controller: str
    mismatch: str
    seed: int
    latency: str = "none"
    ctl: tuple[tuple[str, str], ...] = ()  # dotted controller overrides

    @property
    def key(self) -> results.Key:
        return self.scenario.name, self.controller, self.seed


def _row(job: Job, **fields: Any) -> dict[str, Any]:
    return {"scenario": job.scenario.name, "controller": job.controller, "seed": job.seed, "latency": job.latency,
            **fields}


def execute(job: Job) -> dict[str, Any]:
    """One run in this process: {"row": its results.csv row, "summary": its summary as data or None};
    an exception becomes the row's verdict "error"."""
    try:
        from validation.closed_loop import run
        s = run(job.scenario, controller=job.controller, ctl=dict(job.ctl), mismatch=job.mismatch, seed=job.seed,
                latency=job.latency).to_dict()
    except Exception as e:  # a failed run is recorded, never fatal to the campaign
        return {"row": _row(job, verdict="error", reason=f"{type(e).__name__}: {e}".splitlines()[0]), "summary": None}
    row = _row(job, **{k: s[k] for k in results.FIELDS if k in s and k not in ("scenario", "controller", "seed")})
    row["modes"] = " > ".join(s["modes"])
    for m in MODES:
        if m in s["solve_time"]:
            timing = s["solve_time"][m]
            row.update({f"step_p95_{m}_ms": 1e3 * timing["p95_s"], f"steps_{m}": timing["steps"],
                        f"overruns_{m}": timing["overruns"]})
    return {"row": row, "summary": s}


def run_isolated(job: Job, timeout: float | None = None) -> dict[str, Any]:
    """One run in this thread's child process (validation.isolated): execute's result, or the row of its timeout
    or of its process's death."""
    out = isolated.call("run", job, timeout)
    if out.result is not None:
        return out.result
    return {"row": _row(job, verdict=out.verdict, reason=out.reason, wall_clock_s=out.wall_s), "summary": None}


def _build_on_host(scenarios: Sequence[Scenario], controllers: Sequence[str], ctl: dict[str, str]) -> int:
    out = isolated.call("build", (list(scenarios), list(controllers), ctl))
    if out.result is None:
        raise RuntimeError(f"compiling ahead failed: {out.reason}")
    return int(out.result)


class LocalPool:
    """`workers` threads, each supervising one run's process at a time."""

    name = "local"

    def __init__(self, workers: int):
        self.workers = max(1, workers)
        self._pool = ThreadPoolExecutor(self.workers)

    @property
    def slots(self) -> int:
        return self.workers

    def describe(self) -> dict[str, Any]:
        return {"engine": "local process pool", "workers": self.workers}

    def build(self, scenarios: Sequence[Scenario], controllers: Sequence[str], ctl: dict[str, str]) -> None:
        from validation import precompile
        precompile.build(scenarios, controllers, ctl, self.workers)

    def submit(self, fn: Callable, *args: Any) -> Any:
        return self._pool.submit(fn, *args)

    def first_done(self, pending: Sequence[Any]) -> set:
        return wait(pending, return_when=FIRST_COMPLETED).done

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)


class DaskCluster:
    """A Dask distributed cluster: an existing scheduler's address, or "local:N" (a LocalCluster of
    N single-threaded worker processes on this machine, stopped with the campaign)."""

    name = "dask"

    def __init__(self, address: str):
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise ValueError("--cluster needs Dask distributed; allowed: pip install distributed") from None
        self._cluster = None
        if address.startswith("local:"):
            n = address.removeprefix("local:")
            if not n.isdigit() or int(n) < 1:
                raise ValueError(f"--cluster {address!r}; allowed: local:N with N >= 1 workers, or a scheduler "
                                 "address such as tcp://host:8786")
            self._cluster = LocalCluster(n_workers=int(n), threads_per_worker=1, processes=True,
                                         dashboard_address=None)
            address = self._cluster.scheduler_address
        try:
            self.client = Client(address, timeout=30)
        except (OSError, TimeoutError) as e:
            raise ValueError(f"--cluster {address}: no Dask scheduler answered ({e}); allowed: the address "
                             "printed by `dask scheduler`, e.g. tcp://host:8786, or local:N") from None
        self.address = address

    def _workers(self) -> dict[str, dict[str, Any]]:
        self.client.wait_for_workers(1, timeout=120)
        return self.client.scheduler_info(n_workers=-1)["workers"]

    @property
    def slots(self) -> int:
        return sum(int(w.get("nthreads", 1)) for w in self._workers().values())

    def describe(self) -> dict[str, Any]:
        workers = self._workers()
        return {"engine": "dask distributed", "scheduler": self.address, "workers": len(workers),
                "threads": self.slots, "hosts": sorted({w["host"] for w in workers.values()})}

    def build(self, scenarios: Sequence[Scenario], controllers: Sequence[str], ctl: dict[str, str]) -> None:
        """Compile ahead once per host (on one of its workers), into that host's cache."""
        first: dict[str, str] = {}
        for addr, w in self._workers().items():
            first.setdefault(w["host"], addr)
        futures = [self.client.submit(_build_on_host, list(scenarios), list(controllers), ctl, workers=[addr],
                                      allow_other_workers=False, pure=False) for addr in first.values()]
        for f in tqdm(futures, desc=f"compiling on {len(futures)} hosts", unit="host"):
            f.result()

    def submit(self, fn: Callable, *args: Any) -> Any:
        return self.client.submit(fn, *args, pure=False)

    def first_done(self, pending: Sequence[Any]) -> set:
        from distributed import wait as dask_wait
        return dask_wait(list(pending), return_when="FIRST_COMPLETED").done

    def close(self) -> None:
        self.client.close()
        if self._cluster is not None:
            self._cluster.close()


def engine(workers: int, cluster: str | None) -> LocalPool | DaskCluster:
    return DaskCluster(cluster) if cluster else LocalPool(workers)


def plan(scenarios: Sequence[Scenario], controllers: Sequence[str], mismatch: str, seeds: Sequence[int],
         latency: str, ctl: dict[str, str] | None) -> dict[str, Any]:
    """What the campaign is, as JSON data (what a resume must match)."""
    data = {"scenarios": [{"name": sc.name, **sc.to_data()} for sc in scenarios], "controllers": list(controllers),
            "ctl": dict(ctl or {}), "mismatch": mismatch, "seeds": list(seeds), "latency": latency}
    return json.loads(json.dumps(data))


def _stream(eng: LocalPool | DaskCluster, jobs: Sequence[Job], timeout: float | None) -> Iterator[dict[str, Any]]:
    """Each job's result as it finishes, at most twice the engine's slots in flight (so memory does not
    grow with the number of runs)."""
    todo, pending = iter(jobs), {}
    window = 2 * eng.slots

    def top_up() -> None:
        while len(pending) < window and (job := next(todo, None)) is not None:
            pending[eng.submit(run_isolated, job, timeout)] = job

    top_up()
    while pending:
        for f in eng.first_done(list(pending)):
            job = pending.pop(f)
            try:
                yield f.result()
            except Exception as e:  # the engine lost the task (its worker process or host went away)
                reason = f"{isolated.DIED}: {type(e).__name__}: {e}".splitlines()[0]
                yield {"row": _row(job, verdict=isolated.DIED, reason=reason), "summary": None}
        top_up()


def campaign(scenarios: Sequence[Scenario], controllers: Sequence[str], workers: int, out: Path,
             mismatch: str = "", seeds: int = 1, first_seed: int = 0, latency: str = "none",
             ctl: dict[str, str] | None = None, cluster: str | None = None, resume: bool = False,
             timeout: float | None = None, quiet: bool = False) -> list[dict[str, str]]:
    """Run every scenario with every controller and every seed first_seed..first_seed+seeds-1 of the
    mismatch (the same draws for every controller), with the computation delay `latency`
    (validation.closed_loop.parse_latency), into the folder `out` (module docstring); returns the
    rows of results.csv in the campaign's order."""
    from validation.closed_loop import parse_latency

    parse_latency(latency)  # a bad spec fails here, in one line, not in every run
    if timeout is not None and not timeout > 0:
        raise ValueError(f"timeout {timeout}; allowed: a number of seconds > 0")
    seed_list = list(range(first_seed, first_seed + seeds))
    what = plan(scenarios, controllers, mismatch, seed_list, latency, ctl)
    results.check(out, what, resume)
    eng = engine(workers, cluster)  # a cluster that does not answer fails here, before anything is written
    try:
        store = results.Store(out, what, resume)
    except ValueError:
        eng.close()
        raise
    overrides = tuple(sorted((ctl or {}).items()))
    jobs = [Job(s, c, mismatch, seed, latency, overrides) for s in scenarios for seed in seed_list for c in controllers]
    before = len(store.done & {j.key for j in jobs})
    todo = [j for j in jobs if j.key not in store.done]
    started, origin, old_manifest = time.perf_counter(), manifest.start(), _read(Path(out) / "manifest.json")
    settings = {**what, "timeout_s": timeout, "runs": len(jobs), "runs_done_before": before,
                "controller_settings": _resolved(controllers, ctl)}
    if resume and old_manifest:
        settings["earlier"] = old_manifest
    manifest.write(Path(out), {**settings, "status": "running"}, None, started=origin)  # a killed campaign keeps it
    try:
        if todo:
            eng.build(scenarios, controllers, dict(ctl or {}))
        with tqdm(total=len(jobs), initial=before, desc="campaign", unit="run", disable=quiet) as bar:
            for res in _stream(eng, todo, timeout):
                store.add(res["row"], res["summary"])
                bar.update()
        where = eng.describe()
    finally:
        eng.close()
        store.close()
        isolated.stop_all()
    rows = results.ordered(list(store.rows()), [j.key for j in jobs])
    (Path(out) / "results.md").write_text(report.markdown(rows))
    if rows:
        report.plot(rows, Path(out) / "success.png")
    manifest.write(Path(out), {**settings, "engine": where, "status": "finished"}, time.perf_counter() - started,
                   started=origin)
    return rows


def _read(path: Path) -> dict[str, Any] | None:
    with contextlib.suppress(OSError, ValueError):
        return json.loads(path.read_text())
    return None


def _resolved(controllers: Sequence[str], ctl: dict[str, str] | None) -> dict[str, Any]:
    from validation import presets

    out: dict[str, Any] = {}
    for c in controllers:
        try:
            r = presets.resolve(c, ctl)
            out[c] = {"class": f"{r.cls.__module__}:{r.cls.__qualname__}", "overrides": r.overrides,
                      "settings": r.settings_dict()}
        except ValueError as e:
            out[c] = {"error": str(e)}
    return out
