"""An experiment's manifest: what made a result folder (command, commit, resolved settings), where
(host, CPU, versions), when and how long; written by the tool beside its results."""

from __future__ import annotations

import contextlib
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Iterator
from importlib import metadata
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("casadi", "mujoco", "numpy", "dm-control", "rerun-sdk", "distributed")


def _git(*args: str) -> str:
    try:
        out = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, check=True)
        return out.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ""


def _cpu() -> str:
    """The CPU's model name (/proc/cpuinfo where it exists, else what platform knows)."""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine()


def host() -> dict[str, Any]:
    versions = {}
    for p in PACKAGES:
        try:
            versions[p] = metadata.version(p)
        except metadata.PackageNotFoundError:
            versions[p] = None
    return {"name": platform.node(), "cpu": _cpu(), "cores": os.cpu_count(), "machine": platform.machine(),
            "python": platform.python_version(), "packages": versions}


def start() -> dict[str, Any]:
    """What a result's making starts from: the commit (and whether the tree differs from it) and the
    date, taken when the work starts (the tree may change while it runs)."""
    return {"commit": _git("rev-parse", "HEAD"), "dirty": bool(_git("status", "--porcelain", "--untracked-files=no")),
            "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")}


def manifest(settings: dict[str, Any], wall_time_s: float | None, command: list[str] | None = None,
             started: dict[str, Any] | None = None) -> dict[str, Any]:
    """The manifest of a result made with `settings` (resolved, plain data) in `wall_time_s`, from
    `started` (`start()` when the work began; now if not given); wall_time_s None: still running."""
    return {"command": " ".join(command if command is not None else ["uvms", *sys.argv[1:]]),
            **(started or start()), "wall_time_s": wall_time_s, "host": host(), "settings": settings}


@contextlib.contextmanager
def recorded(path: Path, settings: dict[str, Any] | None = None) -> Iterator[None]:
    """Write a benchmark's manifest to `path` when the block ends without error (command: the
    script and its arguments; commit and date: at the start)."""
    origin, t0 = start(), time.perf_counter()
    yield
    command = [Path(sys.argv[0]).name if sys.argv[0].endswith(".py") else sys.argv[0], *sys.argv[1:]]
    Path(path).write_text(json.dumps(manifest(settings or {}, time.perf_counter() - t0, ["python", *command],
                                              origin), indent=1, default=str))


def write(folder: Path, settings: dict[str, Any], wall_time_s: float | None, command: list[str] | None = None,
          started: dict[str, Any] | None = None) -> Path:
    path = Path(folder) / "manifest.json"
    path.write_text(json.dumps(manifest(settings, wall_time_s, command, started), indent=1, default=str))
    return path
