"""Configurations handed to a planner: joint-limit checks and offline robots.

A configuration of the array is an (n, 2) float64 array of (alpha, beta) angles in
degrees, one row per robot in the geometry's robot order. Offline robots are given as
``{robot_id: (alpha, beta)}``: they never move and sit at those angles.
:func:`apply_offline` is the one place that turns such a mapping into a movable mask
and writes the offline angles into a configuration; every planner entry (and the CLI)
goes through it, so the checks and their error messages are the same everywhere.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError, UnknownRobotError
from rfp_twin.planners.plan.targets import check_limits



def apply_offline(geom: ArrayGeometry, offline: Mapping[int, Sequence[float]] | None,
                  config: np.ndarray | None = None) -> np.ndarray:
    """Check offline robots against the geometry and write their angles into ``config``.

    Parameters
    ----------
    geom : ArrayGeometry
    offline : {robot_id: (alpha, beta) deg} or None; robots that never move, at these
        angles (within the spec's joint limits)
    config : (n, 2) float64 array, deg, or None; each offline robot's row is set to its
        angles, in place (e.g. the targets, the start, or the fixed rows of a random draw)

    Returns
    -------
    movable : (n,) bool, False for the offline robots

    Raises
    ------
    UnknownRobotError
        ``"offline robot 999: <layout>: robot id 999 is not in the layout; allowed: ..."``
        (also for the id of a fiducial).
    TargetError
        Angles that are not two finite numbers within the limits, e.g. ``"offline:
        robot 7: field 'alpha' = 400.0; allowed: [0.0, 360.0] deg"``, or a ``config``
        that is not (n, 2).
    """
    movable = np.ones(geom.n_robots, dtype=bool)
    if not offline:
        return movable
    if config is not None and np.shape(config) != (geom.n_robots, 2):
        raise TargetError(f"offline: configuration shape {np.shape(config)}; allowed: "
                          f"({geom.n_robots}, 2) (one (alpha, beta) row per robot, deg)")
    rows = {}
    for rid, ang in offline.items():
        try:
            k = geom.layout.robot_index(int(rid))
        except UnknownRobotError as exc:
            raise UnknownRobotError(f"offline robot {rid}: {exc}") from None
        a = np.asarray(ang, dtype=np.float64)
        if a.shape != (2,):
            raise TargetError(f"offline robot {rid}: angles {ang!r}; allowed: (alpha, beta) deg")
        check_limits(geom, a[None, :], [rid], "offline")
        rows[k] = a
    for k, a in rows.items():       # all checked: nothing is half-written on an error
        movable[k] = False
        if config is not None:
            config[k] = a
    return movable
