"""Headless rendering (MUJOCO_GL=egl: Mesa's llvmpipe, no GPU, no display) and the demo's outputs."""

from __future__ import annotations

import json

import imageio.v2 as imageio
import numpy as np

from uvms_mj.demo import run
from uvms_mj.plant import Plant
from uvms_mj.render import VideoRecorder


def test_video_of_the_plant_is_written_and_shows_the_vehicle(params, scene, tmp_path) -> None:
    """Ten frames to MP4; read back: 10 frames of 480x640, and the vehicle is in the picture
    (frames with and without the hull differ in more than 1% of the pixels)."""
    plant = Plant(params, scene)
    path = tmp_path / "clip.mp4"
    with VideoRecorder(plant, path) as video:
        for _ in range(10):
            video.capture()
            plant.step(np.zeros(params.n_inputs), 0.04)
    frames = list(imageio.get_reader(path).iter_data())
    assert len(frames) == 10 and frames[0].shape == (480, 640, 3)
    hidden = Plant(params, scene)
    hidden.model.geom_rgba[:, 3] = np.where(hidden.model.geom_contype == 1, 0.0, hidden.model.geom_rgba[:, 3])
    with VideoRecorder(hidden, tmp_path / "hidden.mp4") as video:
        video.capture()
    without = next(imageio.get_reader(tmp_path / "hidden.mp4").iter_data())
    changed = np.mean(np.abs(frames[0].astype(int) - without.astype(int)).max(axis=2) > 30)
    assert changed > 0.01


def test_demo_writes_video_and_time_series(tmp_path) -> None:
    rows = run(tmp_path, duration=2.0)
    assert (tmp_path / "plant_demo.mp4").stat().st_size > 10_000
    saved = json.loads((tmp_path / "plant_demo.json").read_text())
    assert saved == json.loads(json.dumps(rows))
    assert abs(rows[-1]["roll_deg"]) < abs(rows[0]["roll_deg"])  # it is righting itself
