"""Encoding frames: (height, width, 3) uint8 RGB arrays, top row first, into an H.264 MP4
(libx264 through imageio-ffmpeg, yuv420p, so width and height in pixels must be even)
or a PNG. Files are written atomically: a temp file beside the target, renamed onto it
when complete, removed on error.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import imageio_ffmpeg
import numpy as np

from rfp_twin.models.files import atomic_write_bytes
from rfp_twin.twin.render.backend import RenderError


class Mp4Writer:
    """Frames (height, width, 3) uint8 into an H.264 MP4 (imageio-ffmpeg), written to a
    temp file beside ``path`` and renamed onto it by :meth:`close` (removed on error).

    Parameters
    ----------
    path : the MP4 to write
    width, height : frame size, pixels (even)
    fps : frames per video second
    crf, preset : libx264 quality (0-51, lower is better) and speed preset
    """

    def __init__(self, path: str | Path, width: int, height: int, fps: float,
                 crf: int = 23, preset: str = "veryfast") -> None:
        self.path = Path(path)
        self.size = (int(width), int(height))
        self.frames = 0
        parent = self.path.parent
        try:
            parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{self.path.stem}.", suffix=".tmp.mp4")
            os.close(fd)
        except OSError as exc:
            raise RenderError(f"{self.path}: cannot write here ({exc.strerror}); allowed: a path "
                              "in a writable folder") from None
        self._tmp = Path(tmp)
        self._gen = imageio_ffmpeg.write_frames(
            str(self._tmp), self.size, fps=float(fps), codec="libx264", quality=None,
            pix_fmt_out="yuv420p", macro_block_size=2, ffmpeg_log_level="error",
            output_params=["-preset", preset, "-crf", str(int(crf)), "-movflags", "+faststart"])
        self._gen.send(None)

    def write(self, frame: np.ndarray) -> None:
        """Append one (height, width, 3) uint8 frame."""
        if frame.shape != (self.size[1], self.size[0], 3) or frame.dtype != np.uint8:
            raise RenderError(f"frame of shape {frame.shape} {frame.dtype}; allowed: "
                              f"({self.size[1]}, {self.size[0]}, 3) uint8")
        self._gen.send(np.ascontiguousarray(frame))
        self.frames += 1

    def close(self) -> Path:
        """Finish the file and move it into place; returns the path."""
        if self._gen is None:
            return self.path
        try:
            self._gen.close()
            self._gen = None
            os.chmod(self._tmp, 0o644)
            os.replace(self._tmp, self.path)
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Drop the partial file."""
        gen, self._gen = self._gen, None
        if gen is not None:
            try:
                gen.close()
            except Exception:  # noqa: BLE001 - already failing
                pass
        self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> Mp4Writer:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def save_png(image: np.ndarray, path: str | Path) -> Path:
    """Write an (h, w, 3) uint8 image as PNG, atomically (creating the folder)."""
    import imageio.v3 as iio

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, iio.imwrite("<bytes>", np.asarray(image, dtype=np.uint8),
                                         extension=".png"))
    return path
