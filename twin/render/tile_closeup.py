"""The close-up camera of a tiled twin (:mod:`rfp_twin.models.mjcf.tiled_twin`), which has
no whole-array model: a small model of the part of the array the camera sees, drawn by
:class:`FrameRenderer`.

The close-up looks at one robot from a few pitches away, obliquely; every robot and
obstacle within :data:`VIEW_RADIUS_PITCHES` pitches of it is built into an ordinary grid
model (each keeps its own calibration columns, so it stands where it stands in the whole
array), which draws the frame a whole-array model would (farther robots are hidden or
below a pixel; only the plate's edge differs). The renderer takes whole-array arrays,
(n, 2) angles (deg) and (n,) states in layout robot order, and poses its robots from them.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from rfp_twin.models.mjcf import build_model
from rfp_twin.models.mjcf.tiled_twin import TiledTwin, sub_layout
from rfp_twin.twin.render.backend import RenderError
from rfp_twin.twin.render.frames import FrameRenderer
from rfp_twin.twin.render.settings import RenderSettings

#: The close-up model holds the robots and obstacles within this many pitches.
VIEW_RADIUS_PITCHES = 12.0


def closeup_robot(twin: TiledTwin, settings: RenderSettings) -> int:
    """Robot id the close-up looks at: ``settings.robot_id``, else the robot nearest the
    centre of the layout's bounding box (as the whole-array model's close-up camera)."""
    lay = twin.layout
    if settings.robot_id is not None:
        lay.robot_index(settings.robot_id)          # unknown id: a clear error
        return int(settings.robot_id)
    xy = np.asarray(lay.xy, float)
    centre = (xy.min(axis=0) + xy.max(axis=0)) / 2.0
    return int(lay.robot_ids[int(np.argmin(np.hypot(*(lay.robot_xy - centre).T)))])


class TileCloseupRenderer:
    """:class:`FrameRenderer` of the part of a tiled twin around the close-up robot, fed
    whole-array arrays. Same methods as FrameRenderer (``render``, ``set_angles``, ``set_states``,
    ``project``, ``close``, context manager)."""

    def __init__(self, twin: TiledTwin, settings: RenderSettings) -> None:
        if settings.camera != "closeup":
            raise RenderError(f"field 'camera' = {settings.camera!r}: a tiled twin draws the "
                              "top / oblique cameras with MergedFrameRenderer; allowed here: "
                              "'closeup'")
        rid = closeup_robot(twin, settings)
        lay = twin.layout
        centre = lay.robot_xy[lay.robot_index(rid)]
        radius = VIEW_RADIUS_PITCHES * twin.spec.pitch_mm
        rows = np.flatnonzero(np.hypot(*(np.asarray(lay.xy, float) - centre).T) <= radius)
        part = sub_layout(lay, rows, f"{lay.name}#closeup{rid}")
        self.n_robots = twin.n_robots
        self.settings = settings
        self._robots = lay.robot_indices(part.robot_ids)
        model = build_model(twin.spec, part, twin.geometry, twin.options)
        self.inner = FrameRenderer(model, replace(settings, robot_id=rid))
        self.backend = self.inner.backend

    def _local(self, arr, width: int | None):
        if arr is None:
            return None
        a = np.asarray(arr)
        shape = (self.n_robots, width) if width else (self.n_robots,)
        if a.size != int(np.prod(shape)):
            raise RenderError(f"{'angles' if width else 'states'} of shape {a.shape}; allowed: "
                              f"{shape} (every robot of the array, layout order)")
        return a.reshape(shape)[self._robots]

    def set_angles(self, angles_deg: np.ndarray) -> None:
        self.inner.set_angles(self._local(angles_deg, 2))

    def set_states(self, states: np.ndarray) -> None:
        self.inner.set_states(self._local(states, None))

    def render(self, angles_deg=None, states=None, out=None) -> np.ndarray:
        return self.inner.render(self._local(angles_deg, 2), self._local(states, None), out)

    def project(self, xyz: np.ndarray) -> np.ndarray:
        return self.inner.project(xyz)

    def close(self) -> None:
        self.inner.close()

    def __enter__(self) -> TileCloseupRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
