"""Is a plan safe against the geometry? Independent of ``planners/`` algorithms.

Modules here may import ``models`` and the trajectory data type of ``planners``
(:mod:`planners.trajectory`), never a planner's algorithm nor the planner's distance
code (:mod:`models.geometry2d`): a checker that shares code with what it checks proves
nothing.
"""
