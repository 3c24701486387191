"""The order of the deadlock strategies and the metrics built from their records
(planners/deadlocks/chain.py)."""
from __future__ import annotations

import numpy as np

from rfp_twin.planners.deadlocks.chain import (path_generation_seconds, resolution_chain,
                                               resolution_metrics)
from rfp_twin.planners.deadlocks.continuation import ContinuationRecord, ContinuationResolver
from rfp_twin.planners.deadlocks.fold_repair import FoldRepairRecord, FoldRepairResolver
from rfp_twin.planners.deadlocks.replacement import ReplacementRecord
from rfp_twin.planners.deadlocks.rerun import RerunRecord, RerunResolver
from rfp_twin.planners.deadlocks.search.strategy import SearchRecord, SearchResolver
from rfp_twin.planners.plan import PlannerSettings


def kinds(resolvers) -> list[type]:
    return [type(r) for r in resolvers]


def test_greedy_search_tries_reruns_then_the_search_then_continuation():
    chain = resolution_chain(PlannerSettings(), np.random.default_rng(0))
    assert chain.on_run == ()
    assert kinds(chain.on_groups) == [RerunResolver, SearchResolver, ContinuationResolver]
    # the local replacement is the chain's own search, handed in
    assert chain.between_rounds.search_again.__self__ is chain.on_groups[1]


def test_the_settings_leave_strategies_out():
    rng = np.random.default_rng(0)
    markov = resolution_chain(PlannerSettings(algorithm="markov"), rng)
    assert kinds(markov.on_groups) == [SearchResolver, ContinuationResolver]
    bare = resolution_chain(PlannerSettings(reruns=0, continuation=0, local_replace=False), rng)
    assert kinds(bare.on_groups) == [SearchResolver]
    assert bare.between_rounds.search_again is None
    replace = resolution_chain(PlannerSettings(resolve="replace"), rng)
    assert replace.on_groups == () and replace.between_rounds.search_again is None
    assert resolution_chain(PlannerSettings(), rng, resolve=False).on_groups == ()


def test_fold_repair_works_on_the_run_with_beta_first_only():
    rng = np.random.default_rng(0)
    on = resolution_chain(PlannerSettings(beta_first=0.85), rng)
    assert kinds(on.on_run) == [FoldRepairResolver]
    assert resolution_chain(PlannerSettings(beta_first=0.85, fold_repairs=0), rng).on_run == ()
    assert resolution_chain(PlannerSettings(beta_first=0.85, algorithm="roadmap"), rng).on_run == ()


def test_metrics_sum_the_rounds_and_keep_the_last_continuation():
    records = [FoldRepairRecord(3, 0.5), RerunRecord(2, 5, 7, 0.25), SearchRecord(1, 2.0),
               ContinuationRecord(1, 3, 0.125), ReplacementRecord(1, 0, 0.75),
               FoldRepairRecord(1, 0.5), SearchRecord(2, 1.0), ContinuationRecord(0, 0, 0.5),
               ReplacementRecord(2, 2, 0.25)]
    m = resolution_metrics(records, None)
    assert m["search_s"] == 2.0 + 1.0 + 0.75 + 0.25
    assert m["n_search_failed_groups"] == 3 and m["n_replace_groups"] == 3
    assert m["n_local_groups"] == 2 and m["n_fold_repair_runs"] == 4
    assert (m["n_rerun_groups"], m["n_rerun_robots"], m["rerun_attempts"]) == (2, 5, 7)
    assert m["continuation_s"] == 0.625
    assert (m["n_continued_groups"], m["n_continued_robots"]) == (0, 0)   # the last round's
    assert (m["n_search_groups"], m["n_search_robots"], m["n_search_replanned"]) == (0, 0, 0)
    assert path_generation_seconds(records) == 0.5 + 0.25 + 0.5


def test_no_records_give_zeros_of_the_right_types():
    m = resolution_metrics([], None)
    assert all(m[k] == 0.0 and isinstance(m[k], float)
               for k in ("search_s", "continuation_s", "rerun_s"))
    assert all(m[k] == 0 and isinstance(m[k], int) for k in m if not k.endswith("_s"))
