"""What :func:`rfp_twin.twin.render.render_run` wrote: the MP4, its frames and the wall time spent.

Units: times in seconds (``sim_s`` and ``video_s`` of simulated / video time, the others
wall time), frame sizes in pixels, rates in frames per (wall or video) second.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from rfp_twin.twin.sim import SimReport


@dataclass
class RenderReport:
    """What :func:`rfp_twin.twin.render.render_run` wrote.

    path : the MP4; frames : frames written; video_s : frames / fps; sim_s : simulated
    time shown; width, height, fps, speedup, camera : as rendered; backend : MUJOCO_GL;
    render_s : wall time of drawing (scene + GL + read-back); total_s : wall time of the
    whole video (drawing + encoding, not the simulation); sim_wall_s : wall time of the
    simulation (0 when a report was given); state_counts : robot-frames per state.
    """

    path: Path
    frames: int
    video_s: float
    sim_s: float
    width: int
    height: int
    fps: float
    speedup: float
    camera: str
    backend: str
    render_s: float
    total_s: float
    sim_wall_s: float = 0.0
    state_counts: dict[str, int] = field(default_factory=dict)
    sim_report: SimReport | None = field(default=None, repr=False)

    @property
    def fps_rendered(self) -> float:
        """Frames drawn per wall second (drawing only)."""
        return self.frames / self.render_s if self.render_s > 0 else math.inf

    @property
    def fps_achieved(self) -> float:
        """Frames per wall second, drawing and encoding."""
        return self.frames / self.total_s if self.total_s > 0 else math.inf

    def to_dict(self) -> dict:
        """JSON-ready summary (without the simulation report)."""
        return {"path": str(self.path), "frames": self.frames, "video_s": self.video_s,
                "sim_s": self.sim_s, "width": self.width, "height": self.height, "fps": self.fps,
                "speedup": self.speedup, "camera": self.camera, "backend": self.backend,
                "render_s": self.render_s, "total_s": self.total_s, "sim_wall_s": self.sim_wall_s,
                "fps_rendered": self.fps_rendered, "fps_achieved": self.fps_achieved,
                "state_counts": dict(self.state_counts)}
