"""Parameters of one stepwise planning job: :class:`PlannerSettings`.

Units: angles in deg, time in planner steps.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rfp_twin.models.errors import SpecError

if TYPE_CHECKING:
    from rfp_twin.planners.roadmap.alpha_beta import SearchResolveSettings

ALGORITHMS = ("greedy", "markov", "mdp2", "roadmap")
#: (greed, phobia) when not given: the paper's MC setting for markov, SDSS-V's production
#: one (jaeger's configuration of kaiju's MDP2) for mdp2.
DEFAULT_GREED_PHOBIA = {"markov": (0.9, 0.3), "mdp2": (0.7, 0.6)}
DIRECTIONS = ("reverse", "forward")
RESOLVERS = ("search", "replace")


@dataclass(frozen=True)
class PlannerSettings:
    """Parameters of one planning job.

    algorithm : "greedy" | "markov" (the stepwise kernel) | "mdp2" (SDSS-V's production
    generator, :mod:`rfp_twin.planners.stepwise.mdp2`) | "roadmap" (Sabater's
    prioritized planner on every robot, :mod:`rfp_twin.planners.roadmap.alpha_beta.array`);
    step_deg : angular step (deg); greed, phobia : MC / MDP2 parameters in [0, 1] (None:
    markov 0.9 / 0.3, mdp2 0.7 / 0.6); tries : mdp2's tries (>= 1); direction : "reverse" |
    "forward"; max_steps : step limit (default 1000 deg / step, as in the paper);
    max_rounds : deadlock-resolution rounds.
    resolve : "search" (re-plan each deadlocked group with the state-time search of
    :mod:`rfp_twin.planners.deadlocks.search`, keeping its targets; replace a target only
    where the search fails) | "replace" (replace one target per group and re-plan, Sayres
    2021 Sect. 5.2). reruns : with ``resolve="search"`` and the greedy planner, local
    re-runs at most a group with greedy-first Markov robots around it before the search
    (:mod:`rfp_twin.planners.deadlocks.rerun`; 0 = none). search : options of the search
    (None = defaults). continuation : with ``resolve="search"``, Markov runs at most that
    let the groups the search could not resolve go on alone after the plan's end
    (:mod:`rfp_twin.planners.deadlocks.continuation`) before a target is replaced; 0 =
    none. local_replace : with ``resolve="search"``, after a group's robot gets a new
    target the search first plans that group alone again, against everyone else's paths
    of the plan so far; only if a group still fails does a whole new round (a new planner
    run of the array) follow, the same round as without this attempt; the same too when
    the groups' new paths would lengthen the plan.
    beta_first : float >= 0, 0 = off (the paper's GC/MC moves, as kaiju makes them). Else
    in every run of the whole array, the robots whose alpha and beta travel together
    (in steps) is at most this fraction of the run's longest alpha travel retract beta
    first: their obvious move holds alpha until beta is at its destination, and when
    that move is blocked they move as usual. A retracted arm leaves its neighbours room
    to turn, and those robots have the time to spare. fold_repairs : with
    ``beta_first``, whole runs at most per round that switch the rule of the robot
    blocking the last one's alpha, each kept if robots arrive sooner
    (:mod:`rfp_twin.planners.deadlocks.fold_repair`); 0 = none.
    """

    algorithm: str = "greedy"
    step_deg: float = 0.1
    greed: float | None = None
    phobia: float | None = None
    tries: int = 5
    direction: str = "reverse"
    max_steps: int | None = None
    max_rounds: int = 50
    resolve: str = "search"
    search: SearchResolveSettings | None = None
    continuation: int = 8
    reruns: int = 8
    local_replace: bool = True
    beta_first: float = 0.0
    fold_repairs: int = 12

    def __post_init__(self) -> None:
        if self.resolve not in RESOLVERS:
            raise SpecError(f"field 'resolve' = {self.resolve!r}; allowed: {', '.join(RESOLVERS)}")
        if self.algorithm not in ALGORITHMS:
            raise SpecError(f"field 'algorithm' = {self.algorithm!r}; allowed: {', '.join(ALGORITHMS)}")
        if self.direction not in DIRECTIONS:
            raise SpecError(f"field 'direction' = {self.direction!r}; allowed: {', '.join(DIRECTIONS)}")
        if not (np.isfinite(self.step_deg) and 0.001 <= self.step_deg <= 10.0):
            raise SpecError(f"field 'step_deg' = {self.step_deg!r}; allowed: [0.001, 10] deg")
        defaults = DEFAULT_GREED_PHOBIA.get(self.algorithm, DEFAULT_GREED_PHOBIA["markov"])
        for name, default in zip(("greed", "phobia"), defaults):
            if getattr(self, name) is None:
                object.__setattr__(self, name, default)
            v = getattr(self, name)
            if not (np.isfinite(v) and 0.0 <= v <= 1.0):
                raise SpecError(f"field '{name}' = {v!r}; allowed: [0, 1]")
        if self.tries < 1:
            raise SpecError(f"field 'tries' = {self.tries!r}; allowed: >= 1")
        if self.max_steps is not None and self.max_steps < 1:
            raise SpecError(f"field 'max_steps' = {self.max_steps!r}; allowed: >= 1")
        if self.max_rounds < 0:
            raise SpecError(f"field 'max_rounds' = {self.max_rounds!r}; allowed: >= 0")
        if self.continuation < 0:
            raise SpecError(f"field 'continuation' = {self.continuation!r}; allowed: >= 0")
        if self.reruns < 0:
            raise SpecError(f"field 'reruns' = {self.reruns!r}; allowed: >= 0")
        if self.fold_repairs < 0:
            raise SpecError(f"field 'fold_repairs' = {self.fold_repairs!r}; allowed: >= 0")
        if not (np.isfinite(self.beta_first) and 0.0 <= self.beta_first <= 2.0):
            raise SpecError(f"field 'beta_first' = {self.beta_first!r}; allowed: [0, 2] "
                            "(0: off)")

    @property
    def steps_limit(self) -> int:
        return int(self.max_steps or round(1000.0 / self.step_deg))

    @property
    def greedy(self) -> bool:
        return self.algorithm == "greedy"

    @property
    def searches(self) -> bool:
        """Deadlocked groups are searched (``resolve="search"``) before a target is replaced."""
        return self.resolve == "search"
