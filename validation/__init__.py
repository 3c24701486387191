"""Is a plan safe against the geometry? Independent of ``planners/`` algorithms.

Modules here may import ``models`` (the instrument and the trajectory data type,
:mod:`models.trajectory`), never ``planners`` nor the planner's distance
code (:mod:`models.geometry2d`): a checker that shares code with what it checks proves
nothing.
"""
