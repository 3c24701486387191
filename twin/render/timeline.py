"""What each video frame shows: its simulated time, every robot's joint angles and state.

Frames and time
---------------
A video of ``fps`` frames per second at ``speedup`` shows the simulation at sim times
``k * speedup / fps`` s for ``k = 0 .. floor(sim_s * fps / speedup)``: that many frames
+ 1. Joint angles (deg) come from the simulation record (20 ms samples, linearly
interpolated).

Robot states
------------
At each frame a robot is waiting (not moving, not at its end), moving (turning faster
than :data:`MOVING_DEG_S` deg/s on either axis), arrived (within
:data:`ARRIVED_TOL_DEG` deg of where the run ends it on both axes) or in contact (a
contact of the simulation's :class:`rfp_twin.twin.sim.ContactLog` since the previous frame; this
wins over the others).

Shapes: F frames, n robots (layout order).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfp_twin.models.mjcf import TwinModel
from rfp_twin.twin.render.backend import RenderError
from rfp_twin.twin.render.settings import RenderSettings
from rfp_twin.twin.sim import SimReport

#: Robot states, as stored in a timeline's ``states`` array.
WAITING, MOVING, ARRIVED, CONTACT = 0, 1, 2, 3
STATE_NAMES = ("waiting", "moving", "arrived", "contact")
#: A robot turning faster than this on either axis is moving, deg/s.
MOVING_DEG_S = 0.5
#: A robot within this of its final angles on both axes has arrived, deg.
ARRIVED_TOL_DEG = 0.1


@dataclass
class FrameTimeline:
    """What each frame shows: times (F,) sim s; angles (F, n, 2) true joint angles, deg;
    states (F, n) int8 state codes (see :data:`STATE_NAMES`)."""

    times: np.ndarray
    angles: np.ndarray
    states: np.ndarray

    @property
    def n_frames(self) -> int:
        return int(self.times.size)

    def state_counts(self) -> dict[str, int]:
        """Robot-frames in each state."""
        return {name: int(np.count_nonzero(self.states == k)) for k, name in enumerate(STATE_NAMES)}


def frame_times(sim_s: float, settings: RenderSettings) -> np.ndarray:
    """Sim times (F,) s of the frames: ``k * speedup / fps``,
    k = 0 .. floor(sim_s * fps / speedup)."""
    dt = settings.frame_dt_s
    n = int(math.floor(max(0.0, sim_s) / dt + 1e-9)) + 1
    return np.arange(n) * dt


def frame_timeline(twin: TwinModel, report: SimReport, settings: RenderSettings) -> FrameTimeline:
    """Angles and robot states at each frame time of a simulation with a record."""
    rec = report.sampled_record(RenderError)
    times = frame_times(report.sim_s, settings)
    t, a = np.asarray(rec.times, float), np.asarray(rec.angles, float)
    if t.size == 1:
        angles = np.repeat(a[:1], times.size, axis=0)
        speed = np.zeros(angles.shape[:2])
    else:
        i0 = np.clip(np.searchsorted(t, times, side="right") - 1, 0, t.size - 2)
        span = t[i0 + 1] - t[i0]
        w = np.clip((times - t[i0]) / np.where(span > 0, span, 1.0), 0.0, 1.0)[:, None, None]
        angles = a[i0] * (1.0 - w) + a[i0 + 1] * w
        rate = np.abs(a[i0 + 1] - a[i0]) / np.where(span > 0, span, np.inf)[:, None, None]
        speed = rate.max(axis=2)
    final = np.asarray(rec.reference, float)[-1]
    states = np.full(angles.shape[:2], WAITING, dtype=np.int8)
    states[np.abs(angles - final[None]).max(axis=2) <= ARRIVED_TOL_DEG] = ARRIVED
    states[speed > MOVING_DEG_S] = MOVING
    c = report.contacts
    if len(c):
        # a contact at time tc shows on the first frame at or after it
        dt = settings.frame_dt_s
        frame = np.clip(np.ceil(np.asarray(c.time_s) / dt - 1e-9).astype(np.int64), 0, times.size - 1)
        lay = twin.layout
        for ids in (np.asarray(c.robot_a), np.asarray(c.robot_b)):
            keep = ids >= 0
            if keep.any():
                states[frame[keep], lay.robot_indices(ids[keep])] = CONTACT
    return FrameTimeline(times, angles, states)
