"""How to render a video: frame size (pixels), frame rate (frames per video second),
speed-up (simulated seconds per video second), camera, lean CPU settings, H.264 quality.

A video of ``fps`` frames per second at ``speedup`` shows the simulation every
``speedup / fps`` simulated seconds (:attr:`RenderSettings.frame_dt_s`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from rfp_twin.models.mjcf import CAMERAS
from rfp_twin.twin.render.backend import RenderError

#: Largest frame width or height, pixels.
MAX_SIZE = 4096
#: libx264 speed presets.
X264_PRESETS = ("ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow",
                "slower", "veryslow")


@dataclass(frozen=True)
class RenderSettings:
    """How to render.

    width, height : frame size, pixels (even, 16..4096; MP4 / yuv420p needs even sizes).
    fps : video frames per second.
    speedup : simulated seconds per video second (2 = twice real speed).
    camera : ``top``, ``oblique`` or ``closeup`` (the model's cameras).
    robot_id : with ``closeup``, the robot to look at (default: the model's close-up
        robot, nearest the centre).
    lean : cheap CPU render settings (see :mod:`rfp_twin.twin.render.camera` and
        :mod:`rfp_twin.twin.render.frames`); False = MuJoCo defaults.
    fit : move the ``top`` / ``oblique`` camera (orientation and field of view kept) so
        that the whole grid (bases plus arm reach, plate to focal surface) fills the frame,
        centred, with a small margin, for this frame's aspect ratio
        (:func:`rfp_twin.twin.render.camera.fitted_camera`; the model's cameras are framed for a
        square). False: the model's camera poses as they are.
    crf, preset : libx264 quality (0-51, lower is better) and speed preset.
    merged : draw with :class:`rfp_twin.twin.render.merged.MergedFrameRenderer` (the whole
        array in a handful of merged meshes, for large arrays) instead of
        :class:`rfp_twin.twin.render.frames.FrameRenderer` (one draw call per part). None:
        automatic, merged for a wide camera, more than
        :data:`rfp_twin.twin.render.merged.MERGED_MIN_ROBOTS` robots and robots smaller
        than :data:`rfp_twin.twin.render.merged.CAP_PITCH_PX` in the frame
        (:func:`rfp_twin.twin.render.merged.use_merged`). The ``closeup`` camera always
        uses FrameRenderer.
    """

    width: int = 1280
    height: int = 720
    fps: float = 30.0
    speedup: float = 1.0
    camera: str = "top"
    robot_id: int | None = None
    lean: bool = True
    fit: bool = True
    crf: int = 23
    preset: str = "veryfast"
    merged: bool | None = None

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not 16 <= v <= MAX_SIZE or v % 2:
                raise RenderError(f"field '{name}' = {v!r}; allowed: an even integer in "
                                  f"[16, {MAX_SIZE}] pixels")
        for name in ("fps", "speedup"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise RenderError(f"field '{name}' = {v!r}; allowed: a finite number > 0")
        if self.camera not in CAMERAS:
            raise RenderError(f"field 'camera' = {self.camera!r}; allowed: {', '.join(CAMERAS)}")
        if self.robot_id is not None and self.camera != "closeup":
            raise RenderError(f"field 'robot_id' = {self.robot_id!r} with camera {self.camera!r}; "
                              "allowed: a robot id only with camera 'closeup'")
        if isinstance(self.crf, bool) or not isinstance(self.crf, int) or not 0 <= self.crf <= 51:
            raise RenderError(f"field 'crf' = {self.crf!r}; allowed: an integer in [0, 51]")
        if self.merged is not None and not isinstance(self.merged, bool):
            raise RenderError(f"field 'merged' = {self.merged!r}; allowed: True, False or None")
        if self.preset not in X264_PRESETS:
            raise RenderError(f"field 'preset' = {self.preset!r}; allowed: {', '.join(X264_PRESETS)}")

    @property
    def frame_dt_s(self) -> float:
        """Simulated seconds between two frames."""
        return self.speedup / self.fps

    @property
    def wide(self) -> bool:
        """The camera shows the whole grid (``top`` / ``oblique``), not one robot."""
        return self.camera in ("top", "oblique")
