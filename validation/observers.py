"""Observers of the closed loop (validation.closed_loop.run): each sees every physics piece the
plant steps (its report, the step's info, the input applied) and closes at the end of the run."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from controller.protocol import StepInfo, label
from uvms.scene import Plane
from uvms_mj.build import HULL, TIP_GEOM
from uvms_mj.plant import Plant, PlantReport


def main_plane(planes: Sequence[Plane], name: str = "wall") -> int:
    """The index of the plane called `name`, else 0 (the scene's first plane)."""
    return next((i for i, p in enumerate(planes) if p.name == name), 0)


class Observer(Protocol):
    def observe(self, t: float, report: PlantReport, info: StepInfo, u: np.ndarray) -> None:
        """One physics piece from t [s] to report.t, under input u, within the step of `info`."""

    def close(self) -> None: ...


@dataclass(frozen=True)
class ContactTotals:
    """What touched during a run: summed contact-impulse magnitudes [N s] and peak normal forces [N]."""

    hull_impulse: float
    hull_peak: float
    link_impulse: float  # arm links other than the end-effector tip
    tip_peak: float
    min_distance: np.ndarray  # (n_geoms, n_planes) m, smallest signed distance seen
    hull_planes: tuple[str, ...] = ()  # the planes the hull touched, in the order of their first touch


class ContactTally:
    """Sums MuJoCo's contacts by kind: the hull, the tip, the other arm links."""

    def __init__(self, plant: Plant):
        self.hull_impulse = self.hull_peak = self.link_impulse = self.tip_peak = 0.0
        self.min_distance = np.full((len(plant.geom_names), len(plant.scene.planes)), np.inf)
        self.hull_planes: dict[str, None] = {}

    def observe(self, t: float, report: PlantReport, info: StepInfo, u: np.ndarray) -> None:
        self.min_distance = np.minimum(self.min_distance, report.distances)
        for c in report.contacts:
            if c.body == HULL:
                self.hull_impulse += float(np.linalg.norm(c.impulse))
                self.hull_peak = max(self.hull_peak, c.peak_normal_force)
                self.hull_planes.setdefault(c.plane)
            elif c.geom == TIP_GEOM:
                self.tip_peak = max(self.tip_peak, c.peak_normal_force)
            else:
                self.link_impulse += float(np.linalg.norm(c.impulse))

    def totals(self) -> ContactTotals:
        return ContactTotals(self.hull_impulse, self.hull_peak, self.link_impulse, self.tip_peak,
                             self.min_distance.copy(), tuple(self.hull_planes))

    def close(self) -> None:
        """Nothing to release."""


class Telemetry:
    """Per physics piece: time, applied input, state, the wall distances of the hull, the closest
    other link and the tip, the tip's peak force and the mode of the step it belongs to."""

    KEYS = ("t", "u", "h", "hull_distance", "link_distance", "tip_distance", "tip_force", "mode")

    def __init__(self, plant: Plant, plane: str = "wall"):
        """`plane`: the name of the plane whose distances are recorded (the scene's first plane when
        it has none of that name)."""
        names = plant.geom_names
        self.plane = main_plane(plant.scene.planes, plane)
        self.hull = [i for i, g in enumerate(names) if g.startswith(HULL)]
        self.tip = names.index(TIP_GEOM) if TIP_GEOM in names else None
        self.links = [i for i in range(len(names)) if i not in self.hull and i != self.tip]
        self.data: dict[str, list] = {k: [] for k in self.KEYS}

    def observe(self, t: float, report: PlantReport, info: StepInfo, u: np.ndarray) -> None:
        d, j = report.distances, self.plane
        self.data["t"].append(t)
        self.data["u"].append(report.u_applied)
        self.data["h"].append(report.h)
        self.data["hull_distance"].append(float(d[self.hull, j].min()))
        self.data["link_distance"].append(float(d[self.links, j].min()) if self.links else np.nan)
        self.data["tip_distance"].append(float(d[self.tip, j]) if self.tip is not None else np.nan)
        self.data["tip_force"].append(max((c.peak_normal_force for c in report.contacts if c.geom == TIP_GEOM),
                                          default=0.0))
        self.data["mode"].append(label(info.mode))

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self.data.items()}

    def close(self) -> None:
        """Nothing to release."""


class Video:
    """A headless MP4 (uvms_mj.render) at `fps`, one frame each 1/fps s of simulated time."""

    def __init__(self, plant: Plant, path: Path, fps: int = 25):
        from uvms_mj.render import VideoRecorder

        self.plant, self.fps, self.next_frame = plant, fps, 0.0
        self.recorder = VideoRecorder(plant, path, fps=fps)

    def observe(self, t: float, report: PlantReport, info: StepInfo, u: np.ndarray) -> None:
        while self.next_frame <= self.plant.t + 1e-9:
            self.recorder.capture()
            self.next_frame += 1.0 / self.fps

    def close(self) -> None:
        self.recorder.close()
