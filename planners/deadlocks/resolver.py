"""The interface of every deadlock strategy, and the round of planning they work on.

A *round* is one planner run of the whole array towards the round's targets
(:class:`Round`, in the planning frame: reverse planning goes from the targets to the
folded state). The strategies of :mod:`rfp_twin.planners.deadlocks` are tried on it in
the order of :mod:`rfp_twin.planners.deadlocks.chain`; each is a :class:`Resolver`: it
says whether it applies to the round as it stands, and :meth:`Resolver.resolve` changes
the round (its run, its stuck robots and groups, the searched paths, the targets) and
returns a typed record (a frozen dataclass) of what it did, from which the plan's
metrics are built.

Units: angles in deg, lengths in mm, time in planner steps; wall time in s.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.planners.deadlocks.groups import deadlocked_groups, stuck_mask
from rfp_twin.planners.plan.result import build_paths
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
from rfp_twin.planners.stepwise import StepRun


class GroupOutcome(Protocol):
    """One group as a search left it."""

    success: bool


class SearchedPlan(Protocol):
    """The plan as a search of its groups left it
    (:class:`rfp_twin.planners.deadlocks.search.SearchOutcome`): every robot's path on the
    step clock (``paths``, planning frame), the plan's length ``n_steps``, one outcome per
    group searched (``groups``), the search's wall time (``seconds``)."""

    paths: PathSet
    n_steps: int
    groups: list[GroupOutcome]
    seconds: float

    @property
    def resolved_robots(self) -> np.ndarray:
        """(k,) int64, the deadlocked robots whose groups the search resolved."""


@dataclass
class Round:
    """One planner run of the array and what the strategies made of it.

    Attributes
    ----------
    geom : ArrayGeometry; settings : PlannerSettings
    seed : int, the round's seed (each strategy derives its own from it)
    targets : (n, 2) deg, the round's targets (a replacement sets the next round's)
    original : (n, 2) deg, the targets asked for
    replaced : (n,) bool, robots whose target was replaced so far (every round)
    fold : (n, 2) deg, the folded state (offline robots: where they stand)
    movable : (n,) bool
    md : float, mm, the step rule's margin at ``settings.step_deg``
    run : StepRun, the round's run (a strategy may swap in a better one)
    stuck : (n,) bool, movable robots not at their destination in the plan so far
    groups : list of (k,) int64, the deadlocked groups still to resolve
    search : the search's outcome once it re-planned groups (its paths are then the
        plan's), else None
    hardest : per group of ``groups`` once searched, the robot the search could least
        plan (-1: none), the first to get a new target
    partial : bool, ``run`` is a whole-array re-run whose stuck robots wandered until its
        step cap (a search had better plan them from step 0)
    """

    geom: ArrayGeometry
    settings: PlannerSettings
    seed: int
    targets: np.ndarray
    original: np.ndarray
    replaced: np.ndarray
    fold: np.ndarray
    movable: np.ndarray
    md: float
    run: StepRun
    stuck: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    groups: list = field(default_factory=list)
    search: SearchedPlan | None = None
    hardest: list = field(default_factory=list)
    partial: bool = False

    @property
    def reverse(self) -> bool:
        return self.settings.direction == "reverse"

    @property
    def start(self) -> np.ndarray:
        """(n, 2) deg, where the planning frame starts: the targets when reverse."""
        return self.targets if self.reverse else self.fold

    @property
    def goal(self) -> np.ndarray:
        """(n, 2) deg, where the planning frame ends: the folded state when reverse."""
        return self.fold if self.reverse else self.targets

    def settle(self) -> None:
        """Stuck robots and their groups as ``run`` leaves them."""
        self.stuck = stuck_mask(self.run, self.goal, self.movable)
        self.groups = deadlocked_groups(self.geom.pairs, self.stuck)

    def run_paths(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``run`` as CSR paths (ptr (n + 1,), steps (m,), angles (m, 2) deg)."""
        run = self.run
        return build_paths(self.geom.n_robots, run.ev_robot, run.ev_step, run.ev_angles,
                           self.start, run.final, run.n_steps)

    def paths(self) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        """The plan so far: (n_steps, ptr, steps, angles), the searched paths if any."""
        if self.search is not None:
            return (self.search.n_steps,) + tuple(self.search.paths.to_csr(self.search.n_steps))
        return (self.run.n_steps,) + tuple(self.run_paths())


class Record(Protocol):
    """What a strategy did in one round (a frozen dataclass); ``seconds`` its wall time."""

    seconds: float


class Resolver(Protocol):
    """A deadlock strategy."""

    def applies(self, rnd: Round) -> bool:
        """Whether it is tried on ``rnd`` as it stands (the chain offers it only groups
        that are left)."""

    def resolve(self, rnd: Round) -> Record:
        """Resolve what it can of ``rnd`` (changed in place); what it did."""
