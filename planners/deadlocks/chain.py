"""The deadlock strategies in the order they are tried, and the metrics of what they did.

In each round (:class:`rfp_twin.planners.deadlocks.resolver.Round`):

1. on the run itself, before its stuck robots are counted: fold repair (beta-first
   plans, not the roadmap planner);
2. on the deadlocked groups, cheapest first, each on the groups the one before left
   (``resolve="search"``): local re-runs (greedy plans), the state-time search, the
   continuation of the groups the search left;
3. after a round with groups left: one new target per group, the replaced groups
   searched again in place (``local_replace``); a new round when that fails.

Units: wall time in s.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfp_twin.planners.deadlocks.continuation import ContinuationRecord, ContinuationResolver
from rfp_twin.planners.deadlocks.fold_repair import FoldRepairRecord, FoldRepairResolver
from rfp_twin.planners.deadlocks.replacement import ReplacementRecord, ReplacementResolver
from rfp_twin.planners.deadlocks.rerun import RerunRecord, RerunResolver
from rfp_twin.planners.deadlocks.resolver import Record, Resolver
from rfp_twin.planners.deadlocks.search import SearchOutcome
from rfp_twin.planners.deadlocks.search.strategy import SearchRecord, SearchResolver, search_counts
from rfp_twin.planners.plan.settings import PlannerSettings


@dataclass(frozen=True)
class Chain:
    """The strategies of one plan: ``on_run`` (step 1), ``on_groups`` (step 2, in
    order), ``between_rounds`` (step 3)."""

    on_run: tuple[Resolver, ...]
    on_groups: tuple[Resolver, ...]
    between_rounds: Resolver


def resolution_chain(settings: PlannerSettings, rng: np.random.Generator,
                     resolve: bool = True) -> Chain:
    """The strategies ``settings`` ask for (``resolve=False``: no group strategy);
    ``rng`` draws the replaced targets."""
    s = settings
    search = SearchResolver(s) if resolve and s.searches else None
    on_groups = [RerunResolver(s)] if search is not None and s.reruns > 0 and s.greedy else []
    if search is not None:
        on_groups.append(search)
        if s.continuation > 0:
            on_groups.append(ContinuationResolver(s))
    repair = s.beta_first > 0 and s.fold_repairs > 0 and s.algorithm != "roadmap"
    return Chain((FoldRepairResolver(s),) if repair else (), tuple(on_groups),
                 ReplacementResolver(s, rng, search.search_replaced if search is not None
                                     and s.local_replace else None))


def path_generation_seconds(records: list[Record]) -> float:
    """Wall time of the strategies that run the planner again (fold repairs, re-runs),
    which counts as path generation (``tau_sr``)."""
    return sum((r.seconds for r in records if isinstance(r, (FoldRepairRecord, RerunRecord))),
               0.0)


def resolution_metrics(records: list[Record], final: SearchOutcome | None) -> dict:
    """The plan's deadlock-resolution metrics from every round's records (sums over
    rounds; the continuation's groups and robots of the last round that ran one) and the
    search outcome of the final plan (``final``, None when it was not searched)."""
    def of(kind):
        return [r for r in records if isinstance(r, kind)]

    search, replaced, reruns = of(SearchRecord), of(ReplacementRecord), of(RerunRecord)
    continued = of(ContinuationRecord)
    last = continued[-1] if continued else ContinuationRecord(0, 0, 0.0)
    n_groups, n_robots, n_replanned = search_counts(final)
    return {
        "search_s": sum((r.seconds for r in search), 0.0) + sum((r.seconds for r in replaced), 0.0),
        "n_search_groups": n_groups, "n_search_robots": n_robots,
        "n_search_replanned": n_replanned,
        "n_search_failed_groups": sum(r.failed_groups for r in search),
        "n_replace_groups": sum(r.groups for r in replaced),
        "continuation_s": sum((r.seconds for r in continued), 0.0),
        "n_continued_groups": last.groups, "n_continued_robots": last.robots,
        "n_rerun_groups": sum(r.groups for r in reruns),
        "n_rerun_robots": sum(r.robots for r in reruns),
        "rerun_attempts": sum(r.attempts for r in reruns),
        "rerun_s": sum((r.seconds for r in reruns), 0.0),
        "n_local_groups": sum(r.local_groups for r in replaced),
        "n_fold_repair_runs": sum(r.runs for r in of(FoldRepairRecord)),
    }
