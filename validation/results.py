"""A campaign's result folder, written as the runs finish: `results.csv` gets one row per run, flushed
and synced to disk at once, after the run's `runs/<scenario>/<controller>/seed-<n>/summary.json`
(written whole, by an atomic rename). A row is the commit mark of its run: a campaign killed at any
moment keeps every finished run, and `uvms campaign --resume` runs only the ones without a row.
`plan.json` holds what the campaign is (its scenarios, controllers, seeds and settings), so a
resume can refuse to mix two different campaigns in one folder.
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

FIELDS = ("scenario", "controller", "seed", "verdict", "modes", "min_hull_distance", "hull_contact_impulse",
          "ee_peak_contact_force", "link_contact_impulse", "max_total_thrust_along_wall_normal",
          "final_task_error", "fallbacks", "switches", "overruns", "wall_clock_s", "step_p95_I_ms", "step_p95_II_ms",
          "step_p95_III_ms", "steps_I", "steps_II", "steps_III", "overruns_I", "overruns_II", "overruns_III",
          "latency", "reason")
TIMING_FIELDS = ("wall_clock_s", "step_p95_I_ms", "step_p95_II_ms", "step_p95_III_ms", "overruns", "overruns_I",
                 "overruns_II", "overruns_III")
CSV, PLAN = "results.csv", "plan.json"

Key = tuple[str, str, int]  # scenario, controller, seed


def key(row: dict[str, Any]) -> Key:
    return str(row["scenario"]), str(row["controller"]), int(row["seed"])


def summary_path(folder: Path, k: Key) -> Path:
    """Where a run's summary.json goes (a controller's `package.module:Class` made a folder name)."""
    scenario, controller, seed = k
    return Path(folder) / "runs" / scenario / controller.replace(":", "-").replace("/", "-") / f"seed-{seed}" \
        / "summary.json"


def _atomic_write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def read_rows(folder: Path) -> list[dict[str, str]]:
    """The complete rows of a folder's results.csv (a line cut short by a kill is not a row)."""
    path = Path(folder) / CSV
    if not path.is_file():
        return []
    text = path.read_text()
    if not text.endswith("\n"):  # the last write was cut: that run is not done
        text = text[:text.rfind("\n") + 1]
    rows = list(csv.DictReader(io.StringIO(text)))
    needed = ("scenario", "controller", "seed", "verdict")  # older campaigns' files have fewer columns
    return [r for r in rows if None not in r and None not in r.values() and all(r.get(f) for f in needed)]


def check(folder: Path, plan: dict[str, Any], resume: bool) -> None:
    """Whether `folder` can take this campaign (nothing is written): one line naming what is wrong."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"output path {folder} is a file; allowed: a writable folder")
    path, plan_path = folder / CSV, folder / PLAN
    if resume:
        if not plan_path.is_file():
            raise ValueError(f"--resume: {folder} holds no campaign ({PLAN} is missing); allowed: the folder of "
                             "a campaign that was stopped")
        old = json.loads(plan_path.read_text())
        if old != plan:
            diff = sorted(k for k in set(old) | set(plan) if old.get(k) != plan.get(k))
            raise ValueError(f"--resume: {folder} holds a campaign with other {', '.join(diff)}; allowed: the "
                             "same campaign's options, or a new --out")
    elif path.exists() or plan_path.exists():
        raise ValueError(f"{folder} already holds a campaign's results; allowed: --resume to finish it, or a new "
                         "--out")


class Store:
    """The result folder of one campaign (module docstring)."""

    def __init__(self, folder: Path, plan: dict[str, Any], resume: bool):
        check(folder, plan, resume)
        self.folder = Path(folder)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise ValueError(f"output path {folder}: {e.strerror}; allowed: a writable folder") from None
        path = self.folder / CSV
        rows = read_rows(self.folder)
        self.done: set[Key] = {key(r) for r in rows}
        self._write_plan(plan)
        # rewrite the complete rows (dropping a cut line) so appends start on a fresh line
        with path.open("w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=FIELDS)
            writer.writeheader()
            writer.writerows(rows)
        self._fh = path.open("a", newline="")
        self._writer = csv.DictWriter(self._fh, fieldnames=FIELDS)

    def _write_plan(self, plan: dict[str, Any]) -> None:
        _atomic_write(self.folder / PLAN, json.dumps(plan, indent=1, sort_keys=True))

    def add(self, row: dict[str, Any], summary: dict[str, Any] | None) -> None:
        """Write a finished run: its summary (when it has one), then its row, synced to disk."""
        k = key(row)
        if summary is not None:
            _atomic_write(summary_path(self.folder, k), json.dumps(summary))
        self._writer.writerow({f: row.get(f, "") for f in FIELDS})
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self.done.add(k)

    def close(self) -> None:
        self._fh.close()

    def rows(self) -> Iterator[dict[str, str]]:
        yield from read_rows(self.folder)


def ordered(rows: Sequence[dict[str, Any]], order: Sequence[Key]) -> list[dict[str, Any]]:
    """Rows in the campaign's order (scenario, seed, controller), whatever order they finished in."""
    rank = {k: i for i, k in enumerate(order)}
    return sorted(rows, key=lambda r: rank.get(key(r), len(rank)))
