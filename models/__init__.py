"""The instrument as it is: robot specs, layouts, kinematics, collision geometry, trajectories.

The bottom layer of rfp-twin (planners, validation and twin import it, never the other
way). Units: mm, degrees, seconds. Errors are :class:`RfpError` subclasses with one-line
messages. ``import models`` is light: the names below load their module (numba, scipy,
trimesh, mujoco) on first use.

Spec: :class:`RobotSpec`, :func:`load_spec`, :func:`list_presets`.
Layout: :class:`Layout`, :func:`layout_by_name`; flat arrays: :class:`ArrayGeometry`.
Kinematics (Sayres 2021 Eqs. 1-2): :func:`forward`, :func:`inverse`, :func:`sample_patrol_zone`.
Plans: :class:`Trajectory`. 3D robot: :class:`RobotGeometry`, :func:`geometry_for_spec`,
:func:`load_geometry`. MuJoCo: :func:`build_model`, :func:`export_model`, :class:`TwinModel`,
:class:`ModelOptions`.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from models.errors import (LayoutError, PlanningError, RfpError, SpecError, TargetError,
                           TrajectoryError, UnknownRobotError)
from models.lazy import lazy_exports
from models.robot import RobotSpec, list_presets, load_spec

#: Public name -> module that defines it, imported on first access.
_LAZY = {
    "Layout": "models.layout", "layout_by_name": "models.layout",
    "ArrayGeometry": "models.array",
    "forward": "models.kinematics", "inverse": "models.kinematics",
    "sample_patrol_zone": "models.kinematics",
    "Trajectory": "models.trajectory",
    "RobotGeometry": "models.geometry", "geometry_for_spec": "models.geometry",
    "load_geometry": "models.geometry",
    "ModelOptions": "models.mjcf", "TwinModel": "models.mjcf", "build_model": "models.mjcf",
    "export_model": "models.mjcf",
}

if TYPE_CHECKING:
    from models.array import ArrayGeometry
    from models.geometry import RobotGeometry, geometry_for_spec, load_geometry
    from models.kinematics import forward, inverse, sample_patrol_zone
    from models.layout import Layout, layout_by_name
    from models.mjcf import ModelOptions, TwinModel, build_model, export_model
    from models.trajectory import Trajectory


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

__all__ = ["LayoutError", "PlanningError", "RfpError", "SpecError", "TargetError",
           "TrajectoryError", "UnknownRobotError", "RobotSpec", "list_presets", "load_spec",
           *_LAZY]
