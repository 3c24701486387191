"""A Rerun recording (.rrd) of a run: arm poses over time, fiber traces, contacts.

What the file holds (entity paths; world frame in mm, z up; timeline ``sim_time``, a
duration in seconds of simulated time):

``robots/<id>``
    the robot frame (static ``Transform3D``: the pose of the robot's base body).
``robots/<id>/body``, ``robots/<id>/alpha``, ``robots/<id>/alpha/beta``
    each link's visual mesh (:meth:`rfp_twin.models.geometry.RobotGeometry.link_meshes`, in its
    link frame, static) and, for alpha and beta, its pose relative to the parent link
    over time (``Transform3D``: the MuJoCo body poses ``xpos``/``xquat`` made relative;
    a body frame is its link frame). A pose is logged only when the robot moved since
    its previous sample, so still robots cost nothing.
``robots/<id>/alpha/beta/fibers``
    the fiber tips the robot carries as points in the beta frame (static): they ride with
    the beta arm.
``fiducials/<id>``, ``gfa/<id>``, ``plate``
    static: a fiducial's mesh, a guide-camera edge's wall box, the plate box.
``traces/<fiber>``
    the path of that fiber of every robot that carries it over the whole run, one line
    strip per robot
    (world frame, static; about one point per :data:`TRACE_SPACING_MM` of path).
``contacts``
    the simulation's contacts (:class:`rfp_twin.twin.sim.ContactLog`) as red points at the
    contact positions, labelled with the pair and depth, on the record time grid; an
    empty set after each contact so that markers vanish when the contact ends.
``summary``
    a markdown summary of the simulation (static).

The file is written to a temp file beside the destination and renamed onto it when
complete; ``rerun rrd verify FILE`` checks it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import mujoco
import numpy as np
import rerun as rr

from rfp_twin.models.errors import RfpError
from rfp_twin.models.mjcf import RGBA, VISUAL_GROUP, TwinModel
from rfp_twin.models.mjcf.tiled_twin import TiledTwin
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.rrd_file import APPLICATION_ID, write_recording
from rfp_twin.twin.record_poses import iter_link_poses, model_parts
from rfp_twin.twin.sim import SimReport, SimSettings, simulate

#: Name of the time line.
TIMELINE = "sim_time"
#: A link pose is logged again when an angle moved more than this since the last one, deg.
POSE_EPS_DEG = 1e-4
CONTACT_RGBA = (1.0, 0.1, 0.05, 1.0)
CONTACT_RADIUS_MM = 0.6
TRACE_RADIUS_MM = 0.08
#: Fiber traces keep about one point per this much path length, mm (an arc of radius
#: 15 mm drawn with 0.5 mm chords is off by 0.002 mm).
TRACE_SPACING_MM = 0.5
FIBER_RADIUS_MM = 0.15
FIBER_RGBA = {"metrology": (0.1, 0.9, 0.2, 1.0), "boss": (0.2, 0.4, 1.0, 1.0),
              "apogee": (1.0, 0.2, 0.2, 1.0)}
DEFAULT_FIBER_RGBA = (0.9, 0.9, 0.2, 1.0)


class RecordError(RfpError):
    """A recording cannot be made: a report without its record, an unwritable output,
    an incomplete run folder."""


@dataclass(frozen=True)
class RecordSettings:
    """What to record.

    dt_s : time between logged poses (default: every sample of the simulation record,
        20 ms); rounded to a whole number of record samples.
    trace_fibers : names of the fibers to trace (default: all of the geometry's fibers).
    contacts : log the contact markers.
    """

    dt_s: float | None = None
    trace_fibers: tuple[str, ...] | None = None
    contacts: bool = True

    def __post_init__(self) -> None:
        if self.dt_s is not None and not (isinstance(self.dt_s, (int, float))
                                          and math.isfinite(self.dt_s) and self.dt_s > 0):
            raise RecordError(f"field 'dt_s' = {self.dt_s!r}; allowed: a finite number > 0 s")


# -- helpers ----------------------------------------------------------------------------------
def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo (w, x, y, z) quaternions -> Rerun (x, y, z, w)."""
    q = np.asarray(wxyz, dtype=np.float64)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def _rgba8(rgba) -> list[int]:
    return [int(round(255 * float(np.clip(c, 0.0, 1.0)))) for c in rgba]


def _mesh3d(mesh, rgba) -> rr.Mesh3D:
    return rr.Mesh3D(vertex_positions=np.asarray(mesh.vertices, np.float32),
                     triangle_indices=np.asarray(mesh.faces, np.uint32),
                     vertex_normals=np.asarray(mesh.vertex_normals, np.float32),
                     albedo_factor=_rgba8(rgba))


def _changed(angles: np.ndarray, eps: float) -> np.ndarray:
    """(T, n) bool, the samples of each robot worth logging: the first, and every one
    whose angles moved more than ``eps`` (deg) from the sample before."""
    keep = np.ones(angles.shape[:2], dtype=bool)
    if angles.shape[0] > 1:
        keep[1:] = np.abs(np.diff(angles, axis=0)).max(axis=2) > eps
    return keep


def _strip(points: np.ndarray, spacing: float = TRACE_SPACING_MM) -> np.ndarray:
    """A (T, 3) path thinned to about one point per ``spacing`` mm of path length (the
    first and last points kept; a still robot gives 2 equal points)."""
    if len(points) < 2:
        return np.vstack([points, points])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    cell = np.floor(s / spacing)
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = cell[1:] != cell[:-1]
    keep[-1] = True
    out = points[keep]
    return out if len(out) >= 2 else np.vstack([out, out])


def _summary_markdown(report: SimReport) -> str:
    d = report.to_dict()
    pairs = [p for p in d["contact_pairs"] if "robot_b" in p]
    fpairs = [p for p in d["contact_pairs"] if "fiducial" in p]
    lines = ["# rfp-twin simulation", "",
             f"- robots: {d['robots']}",
             f"- simulated: {d['sim_s']:.2f} s (trajectory {d['trajectory_s']:.2f} s)",
             f"- robot-robot contacts: {len(pairs)} pairs, max depth {d['max_depth_mm']:.3f} mm",
             f"- robot-fiducial contacts: {len(fpairs)} pairs",
             f"- not reached: {', '.join(map(str, d['not_reached'][:50])) or 'none'}",
             f"- faults: {'; '.join(d['faults']) or 'none'}",
             f"- MuJoCo warnings: {d['warnings'] or 'none'}",
             f"- ok: {d['ok']}"]
    return "\n".join(lines) + "\n"


# -- the recording ----------------------------------------------------------------------------
def record_run(twin: TwinModel | TiledTwin, trajectory: Trajectory | None, out_rrd: str | Path,
               sim_report: SimReport | None = None, faults=(),
               sim_settings: SimSettings | None = None,
               settings: RecordSettings | None = None,
               progress: Callable[[int, int], None] | None = None) -> Path:
    """Write a .rrd recording of a run (see the module docstring for its contents).

    Parameters
    ----------
    twin : TwinModel, or a tiled twin (:mod:`rfp_twin.models.mjcf.tiled_twin`) (not modified)
    trajectory : what to simulate (ignored when ``sim_report`` is given)
    out_rrd : path of the recording (written atomically)
    sim_report : a finished simulation with its record; default: simulate ``trajectory``
        with ``faults`` and ``sim_settings`` (:func:`rfp_twin.twin.sim.simulate`)
    settings : RecordSettings
    progress : called as ``progress(robots_logged, n_robots)`` as the robots are logged
        (part by part: a tiled twin tile by tile)

    Returns
    -------
    Path of the recording.
    """
    settings = settings or RecordSettings()
    if sim_report is None:
        if trajectory is None:
            raise RecordError("record_run needs a trajectory or a simulation report")
        sim_report = simulate(twin, trajectory, faults, sim_settings, record=True)
    sim_report.sampled_record(RecordError)
    return write_recording(out_rrd, lambda rec: _log_run(rec, twin, sim_report, settings,
                                                         progress), RecordError)


def _log_run(rec: rr.RecordingStream, twin, report: SimReport, settings: RecordSettings,
             progress: Callable[[int, int], None] | None = None) -> None:
    geometry = twin.geometry
    record = report.record
    robot_ids = np.asarray(twin.layout.robot_ids)
    # samples to log
    times = np.asarray(record.times, float)
    angles = np.asarray(record.angles, float)
    if settings.dt_s is not None and times.size > 1:
        step = max(1, int(round(settings.dt_s / float(np.median(np.diff(times))))))
        sel = np.arange(0, times.size, step)
        if sel[-1] != times.size - 1:
            sel = np.append(sel, times.size - 1)
        times, angles = times[sel], angles[sel]

    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    rec.log("summary", rr.TextDocument(_summary_markdown(report),
                                       media_type=rr.MediaType.MARKDOWN), static=True)

    # kinematics at every sample: link poses (relative to the parent link) and fiber tips
    fibers = tuple(n for n, _, _ in geometry.params.fibers)
    trace = fibers if settings.trace_fibers is None else tuple(settings.trace_fibers)
    unknown = [f for f in trace if f not in fibers]
    if unknown:
        raise RecordError(f"field 'trace_fibers' = {unknown}; allowed: {', '.join(fibers)}")
    meshes = geometry.link_meshes("visual")
    fiber_colors = [_rgba8(FIBER_RGBA.get(f, DEFAULT_FIBER_RGBA)) for f in fibers]
    mesh_arch = {name: _mesh3d(meshes[name], RGBA[name]) for name in ("body", "alpha", "beta")}
    keep = _changed(angles, POSE_EPS_DEG)
    strips: list[dict[int, np.ndarray]] = [{} for _ in trace]
    logged = 0
    # part by part (a tiled twin: tile by tile, so only one tile's poses are in memory)
    for robots, poses in iter_link_poses(twin, angles, [fibers.index(f) for f in trace]):
        _log_robots(rec, poses, robot_ids[robots], times, keep[:, robots], fibers,
                    fiber_colors, mesh_arch)
        for c in range(len(trace)):
            for j, k in enumerate(robots):
                if len(times) and not np.isnan(poses.tips[0, j, c, 0]):
                    strips[c][int(k)] = _strip(poses.tips[:, j, c])
        logged += robots.size
        if progress is not None:
            progress(logged, robot_ids.size)
    parts = model_parts(twin)
    _log_obstacles(rec, parts, meshes)
    _log_plate(rec, parts)

    # fiber traces over the whole run (robots that carry that fiber)
    for c, name in enumerate(trace):
        own = sorted(strips[c])
        rec.log(f"traces/{name}",
                rr.LineStrips3D([strips[c][k] for k in own], radii=TRACE_RADIUS_MM,
                                colors=[_rgba8(FIBER_RGBA.get(name, DEFAULT_FIBER_RGBA))] * len(own),
                                labels=[f"r{int(robot_ids[k])}" for k in own]), static=True)

    if settings.contacts:
        _log_contacts(rec, report, np.asarray(record.times, float))


def _log_robots(rec: rr.RecordingStream, poses, ids: np.ndarray, times: np.ndarray,
                keep: np.ndarray, fibers: tuple, fiber_colors: list, mesh_arch: dict) -> None:
    """Log robots ``ids`` (r,): their frames, link meshes and fibers (static) and their link
    poses at the samples where they moved (``keep`` (T, r) bool); ``poses`` LinkPoses of
    those robots."""
    for k, rid in enumerate(ids):
        root = f"robots/{int(rid)}"
        rec.log(root, rr.Transform3D(translation=poses.base_pos[k],
                                     quaternion=_xyzw(poses.base_quat[k])), static=True)
        for name, path in (("body", "body"), ("alpha", "alpha"), ("beta", "alpha/beta")):
            rec.log(f"{root}/{path}", mesh_arch[name], static=True)
        own = np.flatnonzero(poses.has_fiber[k])
        rec.log(f"{root}/alpha/beta/fibers",
                rr.Points3D(poses.fiber_local[k, own], radii=FIBER_RADIUS_MM,
                            colors=[fiber_colors[c] for c in own],
                            labels=[fibers[c] for c in own]), static=True)
        rows = np.flatnonzero(keep[:, k])
        tcol = [rr.TimeColumn(TIMELINE, duration=times[rows])]
        for path, t_rel, q_rel in (("alpha", poses.t_alpha, poses.rel_alpha),
                                   ("alpha/beta", poses.t_beta, poses.rel_beta)):
            rec.send_columns(f"{root}/{path}", indexes=tcol,
                             columns=rr.Transform3D.columns(
                                 translation=np.repeat(t_rel[k][None], rows.size, axis=0),
                                 quaternion=_xyzw(q_rel[rows, k])))


def _log_plate(rec: rr.RecordingStream, parts) -> None:
    """The focal plate as one box: the model's, or the box around every tile's plate."""
    lo, hi = [], []
    for m, d, _ in parts:
        plate = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "focal_plate")
        if plate >= 0:
            lo.append(d.geom_xpos[plate] - m.geom_size[plate])
            hi.append(d.geom_xpos[plate] + m.geom_size[plate])
    if lo:
        lo, hi = np.min(lo, axis=0), np.max(hi, axis=0)
        rec.log("plate", rr.Boxes3D(centers=[(lo + hi) / 2.0], half_sizes=[(hi - lo) / 2.0],
                                    colors=[_rgba8(RGBA["plate"])],
                                    fill_mode=rr.components.FillMode.Solid), static=True)


def _log_obstacles(rec: rr.RecordingStream, parts, meshes: dict) -> None:
    """Static obstacles, each once (a tiled twin carries one in every tile near it): a
    fiducial post as the fiducial mesh at its body pose (``fiducials/<id>``), a
    guide-camera edge as its wall box (``gfa/<id>``: the collision box of the model,
    world centre, half sizes and orientation)."""
    fid_arch = None
    done = set()
    for m, d, idx in parts:
        for j, fid in enumerate(idx.fiducial_ids):
            if int(fid) in done:
                continue
            done.add(int(fid))
            body = int(idx.fiducial_body[j])
            geoms = np.flatnonzero((np.asarray(m.geom_bodyid) == body)
                                   & (np.asarray(m.geom_type) == mujoco.mjtGeom.mjGEOM_BOX)
                                   & (np.asarray(m.geom_group) == VISUAL_GROUP))
            if geoms.size:
                quats = np.empty((geoms.size, 4))
                for q, g in zip(quats, geoms):
                    mujoco.mju_mat2Quat(q, d.geom_xmat[g])
                rec.log(f"gfa/{int(fid)}",
                        rr.Boxes3D(centers=d.geom_xpos[geoms], half_sizes=m.geom_size[geoms],
                                   quaternions=_xyzw(quats), colors=[_rgba8(RGBA["fiducial"])],
                                   fill_mode=rr.components.FillMode.Solid), static=True)
                continue
            if fid_arch is None:
                fid_arch = _mesh3d(meshes["fiducial"], RGBA["fiducial"])
            path = f"fiducials/{int(fid)}"
            rec.log(path, fid_arch, static=True)
            rec.log(path, rr.Transform3D(translation=d.xpos[body],
                                         quaternion=_xyzw(d.xquat[body])), static=True)


def _log_contacts(rec: rr.RecordingStream, report: SimReport, grid: np.ndarray) -> None:
    """Contacts binned on the record time grid: at each grid time with contacts since the
    previous one, their points; at the next grid time without, an empty set."""
    c = report.contacts
    if len(c) == 0 or grid.size == 0:
        return
    tc = np.asarray(c.time_s, float)
    b = np.clip(np.searchsorted(grid, tc - 1e-12, side="left"), 0, grid.size - 1)
    order = np.argsort(b, kind="stable")
    b = b[order]
    pos = np.asarray(c.pos_mm, float)[order]
    ra, rb, fid = (np.asarray(x)[order] for x in (c.robot_a, c.robot_b, c.fiducial))
    depth = np.asarray(c.depth_mm, float)[order]
    labels = [f"r{a}-r{o} {dd:.3f} mm" if o >= 0 else f"r{a}-fid{f} {dd:.3f} mm"
              for a, o, f, dd in zip(ra.tolist(), rb.tolist(), fid.tolist(), depth.tolist())]
    bins, counts = np.unique(b, return_counts=True)
    # add an empty entry after each run of bins with contacts
    after = bins + 1
    clear = np.setdiff1d(after[after < grid.size], bins)
    all_bins = np.concatenate([bins, clear])
    lengths = np.concatenate([counts, np.zeros(clear.size, dtype=np.int64)])
    o = np.argsort(all_bins, kind="stable")
    all_bins, lengths = all_bins[o], lengths[o]
    # points must be ordered as the partitions: bins with contacts in order, empties take none
    rec.send_columns(
        "contacts", indexes=[rr.TimeColumn(TIMELINE, duration=grid[all_bins])],
        columns=rr.Points3D.columns(positions=pos, radii=np.full(len(pos), CONTACT_RADIUS_MM),
                                    colors=np.tile(_rgba8(CONTACT_RGBA), (len(pos), 1)),
                                    labels=labels).partition(lengths))


__all__ = ["APPLICATION_ID", "RecordError", "RecordSettings", "TIMELINE", "record_run"]
