"""Is a plan safe against the geometry? Independent of ``planners/`` algorithms.

:mod:`rfp_twin.validation.checker2d` checks a trajectory densely against the 2D capsule model,
:mod:`rfp_twin.validation.mesh3d` against the 3D collision meshes (FCL), and
:mod:`rfp_twin.validation.buffer` calibrates the 2D buffer against the meshes;
:mod:`rfp_twin.validation.numerics` holds what they share. The public names below are loaded
on first use, so ``import rfp_twin.validation.checker2d`` does not pull in FCL or trimesh.

Modules here may import ``models`` (the instrument and the trajectory data type,
:mod:`rfp_twin.models.trajectory`), never ``planners`` nor the planner's distance code
(:mod:`rfp_twin.models.geometry2d`): a checker that shares code with what it checks proves
nothing.
"""
from rfp_twin.models.lazy import lazy_exports

_EXPORTS = {
    "check_trajectory": "checker2d", "CheckReport": "checker2d", "Collision": "checker2d",
    "validate_trajectory": "mesh3d", "Check3DReport": "mesh3d", "Collision3D": "mesh3d",
    "PairDistance": "mesh3d", "LinkModels": "mesh3d", "RobotPair": "mesh3d",
    "calibrate_buffer": "buffer", "write_report": "buffer", "BufferCalibration": "buffer",
}

__all__ = list(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, {name: f"{__name__}.{module}" for name, module in _EXPORTS.items()})
