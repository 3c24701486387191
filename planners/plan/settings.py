"""Parameters of one stepwise planning job: :class:`PlannerSettings`.

Units: angles in deg, time in planner steps.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from rfp_twin.models.options import check_options, option

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
    """Parameters of one planning job, each declared once with its help, unit and range
    (:func:`rfp_twin.models.options.option`; the CLI and ``PlanOptions`` read them from
    here). ``search`` holds the state-time search's own options (None: defaults)."""

    algorithm: str = option("greedy", "greedy | markov (stepwise, Sayres 2021) | mdp2 (SDSS-V's "
                            "production generator, kaiju's MDP2) | roadmap (Sabater 2018 "
                            "prioritized state-time planner on every robot; slow: minutes on "
                            "500 robots)", choices=ALGORITHMS)
    step_deg: float = option(0.1, "Angular step", unit="deg", lo=0.001, hi=10.0)
    greed: float | None = option(None, "Markov / MDP2 greed [default: markov "
                                 f"{DEFAULT_GREED_PHOBIA['markov'][0]}, mdp2 "
                                 f"{DEFAULT_GREED_PHOBIA['mdp2'][0]}]",
                                 lo=0.0, hi=1.0)
    phobia: float | None = option(None, "Markov / MDP2 phobia [default: markov "
                                  f"{DEFAULT_GREED_PHOBIA['markov'][1]}, mdp2 "
                                  f"{DEFAULT_GREED_PHOBIA['mdp2'][1]}]",
                                  lo=0.0, hi=1.0)
    tries: int = option(5, "mdp2: tries, each from the start after the most folded stuck "
                        "robot is nudged", lo=1)
    direction: str = option("reverse", "reverse (targets -> fold, played backwards) | forward",
                            choices=DIRECTIONS)
    max_steps: int | None = option(None, "Step limit [default: 1000 deg / step]", lo=1)
    max_rounds: int = option(50, "Deadlock-resolution rounds", lo=0)
    resolve: str = option("search", "Deadlocks left by the planner run: search (re-run with "
                          "greedy-first Markov robots around the groups, then re-plan each group "
                          "left by state-time search, keeping its targets; replace a target "
                          "only where that fails) | replace (new target for one robot per "
                          "group, Sayres 2021)", choices=RESOLVERS)
    search: SearchResolveSettings | None = None
    continuation: int = option(8, "With resolve=search: Markov runs at most that let the "
                               "groups the search could not resolve go on alone after the "
                               "plan's end, before a target is replaced", lo=0)
    reruns: int = option(8, "With resolve=search and greedy: local re-runs a deadlocked "
                         "group, greedy-first Markov robots around it, before the search "
                         "(0: none)", lo=0)
    local_replace: bool = option(True, "With resolve=search: a group whose robot got a new "
                                 "target is searched again alone before a whole new round")
    beta_first: float = option(0.0, "Robots whose alpha + beta travel is at most this "
                               "fraction of the longest alpha travel retract beta first, "
                               "leaving their neighbours room to turn (0: off, the paper's "
                               "moves)", lo=0.0, hi=2.0)
    fold_repairs: int = option(12, "With beta_first: whole runs at most per round that switch "
                               "the rule of the robot blocking the last robot, kept when "
                               "robots arrive sooner", lo=0)

    def __post_init__(self) -> None:
        defaults = DEFAULT_GREED_PHOBIA.get(self.algorithm, DEFAULT_GREED_PHOBIA["markov"])
        for name, default in zip(("greed", "phobia"), defaults):
            if getattr(self, name) is None:
                object.__setattr__(self, name, default)
        check_options(self)

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
