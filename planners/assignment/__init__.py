"""Collision-aware fiber assignment: a target catalogue -> one pose per robot.

- :mod:`rfp_twin.planners.assignment.candidates`: (robot, target, arm, fiber) poses within
  reach, inside each robot's range and clear of obstacles; parking poses
- :mod:`rfp_twin.planners.assignment.conflicts`: pairs (cliques) of poses that collide
- :mod:`rfp_twin.planners.assignment.problem`: the 0/1 program and its independent components
- :mod:`rfp_twin.planners.assignment.solvers`: CP-SAT and HiGHS backends
- :mod:`rfp_twin.planners.assignment.greedy`: greedy + local improvement (numba)
- :mod:`rfp_twin.planners.assignment.misses`: why a target within reach was not assigned
- :mod:`rfp_twin.planners.assignment.assign`: :func:`assign`, :class:`AssignSettings`,
  :class:`Quotas`, :class:`Assignment`
- :mod:`rfp_twin.planners.assignment.completeness`: :func:`completeness` (science targets
  observed, overall and by priority), :func:`observed_rows`
"""
from rfp_twin.planners.assignment.assign import (DEFAULT_EXACT, MAX_EXACT_ROBOTS, METHODS,
                                                 AssignSettings, Assignment, Quotas, assign,
                                                 relaxed_bound)
from rfp_twin.planners.assignment.candidates import (ARMS, LEFT, PARKED, RIGHT, Candidates,
                                                     build_candidates, parking_angles)
from rfp_twin.planners.assignment.completeness import (completeness, observed_rows,
                                                       reachable_rows)
from rfp_twin.planners.assignment.misses import MISS_REASONS, miss_reasons

__all__ = ["ARMS", "DEFAULT_EXACT", "LEFT", "MAX_EXACT_ROBOTS", "METHODS", "MISS_REASONS",
           "PARKED", "RIGHT", "miss_reasons",
           "AssignSettings", "Assignment", "Candidates", "Quotas", "assign", "build_candidates",
           "completeness", "observed_rows", "reachable_rows", "parking_angles", "relaxed_bound"]
