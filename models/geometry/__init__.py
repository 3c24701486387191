"""The 3D robot: procedural trimesh meshes of each link, or the user's own CAD meshes.

Lengths in mm, angles in degrees, z up. Geometry comes from the ``[geometry]`` table of
a preset (see ``models/presets``); :func:`geometry_for_spec` gives the 3D robot of any
:class:`rfp_twin.models.robot.RobotSpec`. Modules:

- :mod:`rfp_twin.models.geometry.dimensions`: link frames, SDSS-V defaults, :class:`GeometryParams`
- :mod:`rfp_twin.models.geometry.params`: the ``[geometry]`` TOML table, parsed and checked
- :mod:`rfp_twin.models.geometry.shapes`: procedural outlines and meshes (prism, cylinder, union)
- :mod:`rfp_twin.models.geometry.p1`: the published P1 prototype beta arm (``beta_shape = "p1"``)
- :mod:`rfp_twin.models.geometry.cad`: user STL/OBJ meshes and their convex pieces
- :mod:`rfp_twin.models.geometry.robot_geometry`: :class:`RobotGeometry`, built and loaded
"""
from rfp_twin.models.geometry.cad import MESH_SUFFIXES, UNIT_RATIO_LIMIT, load_cad_mesh, slab_pieces
from rfp_twin.models.geometry.dimensions import (BETA_SHAPES, LINKS, MOVING_LINKS, SDSS_V_DEFAULTS,
                                                 GeometryParams, default_params)
from rfp_twin.models.geometry.p1 import (P1_BETA_ARM, P1_END_X_MM, P1_HEAD_Z_MM, P1_SOURCE,
                                         p1_pieces, p1_reach_mm)
from rfp_twin.models.geometry.params import params_from_tables, validate_params
from rfp_twin.models.geometry.robot_geometry import (Link, RobotGeometry, build_geometry,
                                            geometry_for_spec, load_geometry)
from rfp_twin.models.geometry.shapes import alpha_outline, beta_outline, cylinder, prism, union

__all__ = ["BETA_SHAPES", "P1_BETA_ARM", "P1_END_X_MM", "P1_HEAD_Z_MM", "P1_SOURCE", "LINKS", "MESH_SUFFIXES", "MOVING_LINKS", "SDSS_V_DEFAULTS", "UNIT_RATIO_LIMIT",
           "GeometryParams", "Link", "RobotGeometry", "alpha_outline", "beta_outline",
           "build_geometry", "cylinder", "default_params", "geometry_for_spec", "load_cad_mesh",
           "load_geometry", "p1_pieces", "p1_reach_mm", "params_from_tables", "prism", "slab_pieces", "union",
           "validate_params"]
