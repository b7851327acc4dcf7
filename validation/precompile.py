"""Compile ahead: every generated C function a run needs, built before the loop starts, in
parallel over the cores, with a progress bar naming what it compiles (`uvms build`).

A controller is split into pieces that compile independently (Mode I's OCP, the certificate's
minimum-violation problem, Modes II and III per obstacle plane, the model's rollout functions);
each piece is built once in a worker process into the shared on-disk cache (controller.codegen:
atomic renames, so parallel builders never corrupt it). A piece that was built is marked in the
cache under a key of its scenario's vehicle and planes, its settings and the controller's source,
so a warm run checks the markers and starts no worker. A class that is not the switching NMPC or
the braking baseline is built by calling its `reset` once.
"""

from __future__ import annotations

import hashlib
import multiprocessing
import os
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, replace
from pathlib import Path

from tqdm import tqdm

from validation import presets
from validation.scenarios import Scenario

SOURCES = Path(__file__).resolve().parent.parent / "controller"


@dataclass(frozen=True)
class Piece:
    """One independently compiled part of a controller for one scenario's vehicle and planes."""

    scenario: Scenario
    controller: str
    ctl: tuple[tuple[str, str], ...]
    kind: str  # "mode1", "certificate", "mode2", "mode3", "model", "reset"
    plane: int | None = None

    def label(self) -> str:
        where = f", plane {self.plane}" if self.plane is not None else ""
        return f"{self.kind}{where} ({self.scenario.name}, {self.controller})"


def _source_digest() -> str:
    h = hashlib.sha256()
    for path in sorted(SOURCES.glob("*.py")):
        h.update(path.read_bytes())
    return h.hexdigest()


def key(piece: Piece, digest: str) -> str:
    """What makes a piece's compiled code: the vehicle, the planes, the settings it uses, the source."""
    from validation.setup import scene_of

    resolved = presets.resolve(piece.controller, dict(piece.ctl))
    s = resolved.settings
    part = {"mode1": ("mode1",), "certificate": ("mode1", "certificate"), "mode2": ("mode2",),
            "mode3": ("mode3",), "model": (), "reset": ()}[piece.kind]
    settings = repr([getattr(s, p) for p in part]) if part else ("" if piece.kind == "model" else repr(s))
    planes = "" if piece.kind == "model" else repr([(p.name, p.normal.tolist(), p.offset)
                                                    for p in scene_of(piece.scenario).planes])
    extra = repr((resolved.cls.__module__, resolved.cls.__qualname__)) if piece.kind == "reset" else ""
    text = "|".join((digest, piece.scenario.arm, planes, piece.kind, str(piece.plane), settings, extra))
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def pieces(scenarios: Sequence[Scenario], controllers: Sequence[str],
           ctl: dict[str, str] | None = None) -> list[Piece]:
    """The pieces of every scenario-controller pair, without duplicates."""
    from controller.baselines import BrakingController
    from controller.switching import SwitchingController
    from validation.setup import scene_of

    overrides = tuple(sorted((ctl or {}).items()))
    out, seen, digest = [], set(), _source_digest()
    for sc in scenarios:
        for name in controllers:
            cls = presets.resolve(name, ctl).cls
            if cls is SwitchingController:
                n = len(scene_of(sc).planes)
                kinds = [("model", None), ("mode1", None), ("certificate", None)]
                if presets.resolve(name, ctl).settings.switching:
                    kinds += [(k, p) for p in range(n) for k in ("mode2", "mode3")]
            elif cls is BrakingController:
                kinds = [("model", None)]
            else:
                kinds = [("reset", None)]
            for kind, plane in kinds:
                piece = Piece(sc, name, overrides, kind, plane)
                k = key(piece, digest)
                if k not in seen:
                    seen.add(k)
                    out.append(piece)
    return out


def _marker(k: str) -> Path:
    from controller.codegen import CACHE

    return CACHE / "built" / k


def build_piece(piece: Piece) -> str:
    """Build one piece (in a worker process); returns its label."""
    from controller.feasibility import FeasibilityTest
    from controller.mode1 import ModeIOCP
    from controller.mode2 import ModeIIOCP
    from controller.mode3 import ModeIIIOCP
    from controller.model import UVMSModel
    from controller.rollouts import BrakingPolicy
    from validation.closed_loop import task_of
    from validation.setup import build_plant

    resolved = presets.resolve(piece.controller, dict(piece.ctl))
    params, scene, _, _ = build_plant(piece.scenario, "", 0)
    s = resolved.settings
    if piece.kind == "reset":
        presets.build(resolved).reset(task_of(piece.scenario, params, scene))
        return piece.label()
    options = getattr(s, "model_options", None)
    model = UVMSModel(params, scene.water, options()) if options is not None else UVMSModel(params, scene.water)
    if piece.kind == "model":
        task = task_of(piece.scenario, params, scene)
        h0, u = task.h0, BrakingPolicy(model)(task.h0, task.h0[6:6 + params.n_joints])
        model.step(h0, u, 0.01)
        model.held_steps(h0, u, 0.1, 4)
    elif piece.kind == "mode1":
        ModeIOCP(model, scene.planes, s.mode1)
    elif piece.kind == "certificate":
        FeasibilityTest(model, scene.planes, s.mode1, s.certificate)
    elif piece.kind == "mode2":
        ModeIIOCP(model, scene.planes, piece.plane, s.mode2).prepare_guesses(s.mode2.horizon)
    else:  # both of its horizons: with every thruster dead and with some alive (SwitchingNMPC.ocp3)
        for horizon in s.mode3.horizons:
            ModeIIIOCP(model, scene.planes, piece.plane, replace(s.mode3, horizon=horizon)).prepare_twins()
    return piece.label()


def build(scenarios: Sequence[Scenario], controllers: Sequence[str], ctl: dict[str, str] | None = None,
          workers: int | None = None, quiet: bool = False) -> int:
    """Compile every piece the scenario-controller pairs need that is not yet marked built, in
    `workers` processes (default: the cores); returns how many pieces were built."""
    from controller.codegen import CACHE

    digest = _source_digest()
    todo = [(p, k) for p in pieces(scenarios, controllers, ctl) if not _marker(k := key(p, digest)).exists()]
    if not todo:
        return 0
    workers = max(1, min(workers or os.cpu_count() or 1, len(todo)))
    if not quiet:
        print(f"compiling {len(todo)} controller pieces once, cached in {CACHE} ({workers} processes)", flush=True)
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        futures = {pool.submit(build_piece, p): k for p, k in todo}
        bar = tqdm(total=len(futures), desc="compiling", unit="piece", disable=quiet)
        for f in as_completed(futures):
            bar.set_postfix_str(f.result())
            marker = _marker(futures[f])
            marker.parent.mkdir(parents=True, exist_ok=True)
            marker.touch()
            bar.update()
        bar.close()
    return len(todo)
