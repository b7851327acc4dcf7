"""Headless video of a plant: MuJoCo's renderer (EGL when MUJOCO_GL=egl, no GPU or display needed)
written to MP4 by imageio's ffmpeg."""

from __future__ import annotations

from pathlib import Path
from types import TracebackType

import imageio.v2 as imageio
import mujoco

from uvms_mj.plant import Plant


class VideoRecorder:
    """Render frames of `plant` from a named camera into an MP4 file (context manager)."""

    def __init__(self, plant: Plant, path: str | Path, fps: int = 25, width: int = 640, height: int = 480,
                 camera: str = "chase"):
        path = Path(path)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise ValueError(f"video path {path}: cannot create its folder ({e.strerror}); "
                             "allowed: a writable location") from None
        self.plant, self.camera, self.path, self.fps = plant, camera, path, fps
        self._renderer = mujoco.Renderer(plant.model, height=height, width=width)
        self._option = mujoco.MjvOption()
        self._writer = imageio.get_writer(path, fps=fps, codec="libx264", quality=7, macro_block_size=16)
        self.frames = 0

    def capture(self) -> None:
        self._renderer.update_scene(self.plant.data, camera=self.camera, scene_option=self._option)
        self._writer.append_data(self._renderer.render())
        self.frames += 1

    def close(self) -> None:
        self._writer.close()
        self._renderer.close()

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
