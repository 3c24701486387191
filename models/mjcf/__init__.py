"""The grid model for MuJoCo, built with ``mujoco.MjSpec`` (no XML templating).

Units inside the model: mm, kg, s, radians; the public API takes mm and degrees. One
body tree per robot (``r<id>`` > ``r<id>_alpha`` > ``r<id>_beta``, position servos on
both hinges), ``fid<id>`` bodies for obstacles, the focal plate, two lights and three
cameras. Each robot's own geometry from the layout columns (alpha arm, fibers, base
height and axis) and each obstacle's shape (posts, guide-camera walls) are built in
(:mod:`rfp_twin.models.mjcf.bodies`). MuJoCo collides meshes as convex hulls, so
collision geoms are the convex pieces from :mod:`rfp_twin.models.geometry`. The
broadphase only pairs geoms whose boxes overlap, so only neighbours (Sayres 2021 Eq. 4)
reach the narrowphase:
:meth:`TwinModel.neighbour_pairs` lists them. Modules:

- :mod:`rfp_twin.models.mjcf.options`: names, colours, :class:`ServoParams`, :class:`ModelOptions`
- :mod:`rfp_twin.models.mjcf.bodies`: robot and fiducial bodies, meshes, servos, contact bits
- :mod:`rfp_twin.models.mjcf.cameras`: plate, lights, cameras
- :mod:`rfp_twin.models.mjcf.blocks`: robots built into small specs and merged by attaches
  (an MjSpec add costs O(spec size): one big spec would be O(n^2))
- :mod:`rfp_twin.models.mjcf.memory`: MuJoCo's arena sized from the grid; the body-count limit
- :mod:`rfp_twin.models.mjcf.build`: :func:`build_spec`, :func:`build_model`, :func:`export_model`
- :mod:`rfp_twin.models.mjcf.index`, :mod:`rfp_twin.models.mjcf.twin_model`: the compiled model
"""
from rfp_twin.models.mjcf.build import build_model, build_spec, export_model
from rfp_twin.models.mjcf.cameras import closeup_pose, look_at_quat
from rfp_twin.models.mjcf.index import ModelIndex
from rfp_twin.models.mjcf.options import (BIT_ALPHA, BIT_BETA, CAMERAS, COLLISION_CLASS, COLLISION_GROUP,
                                 FIBER_RGBA, MESH_DIR, MODEL_FILE, RGBA, VISUAL_CLASS,
                                 VISUAL_GROUP, ModelOptions, ServoParams,
                                 collect_mujoco_warnings, fiducial_name, robot_name)
from rfp_twin.models.mjcf.twin_model import TwinModel

__all__ = ["BIT_ALPHA", "BIT_BETA", "CAMERAS", "COLLISION_CLASS", "COLLISION_GROUP",
           "FIBER_RGBA", "MESH_DIR", "MODEL_FILE", "RGBA", "VISUAL_CLASS", "VISUAL_GROUP",
           "ModelIndex", "ModelOptions", "ServoParams", "TwinModel", "build_model",
           "build_spec", "closeup_pose", "collect_mujoco_warnings", "export_model",
           "fiducial_name", "look_at_quat", "robot_name"]
