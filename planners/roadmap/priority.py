"""Many arms: search over pairwise priorities with Sabater's single-arm planner.

Sabater et al. 2018 plan arms one at a time in a priority order, an arm planned later
treating the trajectories of the arms before it as moving obstacles (their Algorithm 1),
and retry with other orders when one fails (Sect. 2.1). :func:`priority_search`
searches the orders themselves instead (priority-based search, Ma et al. 2019, AAAI):
on a conflict one arm yields to the other, and an arm with no trajectory may recruit the
fixed obstacles that blocked it as arms below it. Goal conflicts (Sabater 2018 Sect.
6.4.2): each arm's ``hold_until`` is raised to the latest end among the arms above it.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.planners.roadmap.arm import Arm, ArmTrajectory, RoadmapSettings
from rfp_twin.planners.roadmap.planner import plan_arm


@dataclass
class PrioritySearchResult:
    """Outcome of :func:`priority_search`.

    Attributes
    ----------
    trajectories : {arm index: ArmTrajectory}, every arm (recruited ones included) when
        ``success``; empty otherwise
    success : bool
    n_arms : int, arms at the end (initial ones plus recruited ones)
    priorities : set of (higher, lower) pairs of the solution (or of the last node)
    nodes : int, search-tree nodes expanded
    plans : int, single-arm searches run
    seconds : float
    failures : {arm index: single-arm searches that found no trajectory}
    """

    trajectories: dict[int, ArmTrajectory]
    success: bool
    n_arms: int
    priorities: set
    nodes: int
    plans: int
    seconds: float = 0.0
    failures: dict = field(default_factory=dict)


def priority_search(n_arms: int,
                    make_arm: Callable[[int, dict[int, ArmTrajectory], frozenset], Arm],
                    conflict: Callable[[int, ArmTrajectory, int, ArmTrajectory], bool],
                    settings: RoadmapSettings, rng: np.random.Generator, *,
                    recruit: Callable[[int, int], list[tuple[int, ArmTrajectory]]] | None = None,
                    max_nodes: int = 24, max_recruits: int = 6) -> PrioritySearchResult:
    """Depth-first search over pairwise priorities with Sabater's planner for each arm.

    Sabater 2018 plan with one fixed priority order and retry with other orders
    (Sect. 2.1); searching the orders themselves finds more solutions. This is
    priority-based search (Ma et al., AAAI 2019) with :func:`plan_arm` as the
    single-arm planner: each arm is planned against the arms above it in a partial
    order only (``make_arm(i, higher)``: the trajectories of those arms are its moving
    obstacles, the others are ignored). The root plans every arm alone. A node whose
    trajectories conflict pairwise (``conflict``) branches on the first conflict
    (i, j): "i above j" or "j above i"; the lower arm and every arm below it whose
    trajectory now conflicts with one above it are planned again (in topological
    order). A child in which an arm gets no trajectory is dropped, unless ``recruit``
    brings in new arms for it: ``recruit(i, limit)`` returns at most ``limit``
    ``(index, trajectory)`` of arms that arm i met as fixed obstacles and that may now
    get out of its way (they are placed below i; indices continue from the current
    number of arms; at most ``max_recruits`` in all). The first node without conflicts
    is the solution.

    Parameters
    ----------
    n_arms : int, arms at the start
    make_arm : callable ``(i, higher, arms) -> Arm``; ``higher`` = {index: trajectory}
        of the arms above i, its moving obstacles; ``arms`` = the arms of this search
        node: those not in ``higher`` are ignored, and arms recruited in other branches
        (not in ``arms``) are part of the fixed environment again. Goal conflicts: the
        planner raises ``hold_until`` to the latest end among ``higher``.
    conflict : callable ``(i, traj_i, j, traj_j) -> bool``, do arms i and j collide
        (each holding its last configuration after its end)
    settings : RoadmapSettings; rng : numpy Generator
    recruit : see above (optional)
    max_nodes : search-tree nodes expanded at most
    max_recruits : arms recruited at most

    Returns
    -------
    PrioritySearchResult
    """
    clock = time.perf_counter()
    counter = {"plans": 0, "n": n_arms, "recruits": 0}
    base_paths: dict[int, ArmTrajectory] = {}
    failures: dict[int, int] = {}

    def closure_up(prio: dict[int, set], i: int) -> set:
        out, todo = set(), list(prio.get(i, ()))
        while todo:
            h = todo.pop()
            if h not in out:
                out.add(h)
                todo.extend(prio.get(h, ()))
        return out

    def plan(i: int, prio: dict[int, set], paths: dict[int, ArmTrajectory]) -> ArmTrajectory | None:
        higher = {h: paths[h] for h in closure_up(prio, i)}
        arm = make_arm(i, higher, frozenset(range(n_arms)) | frozenset(paths) | {i})
        if higher:
            arm = replace(arm, hold_until=max(arm.hold_until, max(t.t_end for t in higher.values())))
        counter["plans"] += 1
        tr, _ = plan_arm(arm, settings, rng)
        return tr

    def plan_or_recruit(i, prio, paths) -> bool:
        """Plan arm i; if it fails, recruit the arms that blocked it and try once more."""
        tr = plan(i, prio, paths)
        if tr is None and recruit is not None and counter["recruits"] < max_recruits:
            new = list(recruit(i, max_recruits - counter["recruits"]))
            if len(new) > max_recruits - counter["recruits"]:
                raise field_error(SpecError, "recruit", len(new),
                                  f"at most {max_recruits - counter['recruits']} arms", "priority_search")
            if new:
                for j, trj in new:
                    counter["recruits"] += 1
                    counter["n"] = max(counter["n"], j + 1)
                    base_paths[j] = trj
                    paths[j] = trj
                    prio.setdefault(j, set()).add(i)
                tr = plan(i, prio, paths)
        if tr is None:
            failures[i] = failures.get(i, 0) + 1
            return False
        paths[i] = tr
        return True

    def update(prio: dict[int, set], paths: dict[int, ArmTrajectory], low: int) -> bool:
        """Re-plan ``low`` and, in topological order, every arm below it that conflicts."""
        todo = [low] + [a for a in range(counter["n"]) if a in paths and low in closure_up(prio, a)]
        done = set()
        while todo:
            # the next arm none of whose higher arms is still waiting to be updated
            pick = next(a for a in todo if not (closure_up(prio, a) & set(todo) - {a}))
            todo.remove(pick)
            if pick in done:
                continue
            done.add(pick)
            higher = closure_up(prio, pick)
            if pick == low or any(conflict(pick, paths[pick], h, paths[h]) for h in higher):
                if not plan_or_recruit(pick, prio, paths):
                    return False
                # arms recruited meanwhile sit below pick: check them too
                for a in range(counter["n"]):
                    if a in paths and a not in done and a not in todo and pick in closure_up(prio, a):
                        todo.append(a)
        return True

    def first_conflict(paths: dict[int, ArmTrajectory]):
        keys = sorted(paths)
        for x, i in enumerate(keys):
            for j in keys[x + 1:]:
                if conflict(i, paths[i], j, paths[j]):
                    return i, j
        return None

    prio: dict[int, set] = {}
    paths: dict[int, ArmTrajectory] = {}
    for i in range(n_arms):
        if not plan_or_recruit(i, prio, paths):
            return PrioritySearchResult({}, False, counter["n"], set(), 0, counter["plans"],
                                        time.perf_counter() - clock, failures)
    stack = [(prio, paths)]
    nodes = 0
    last_pairs: set = set()
    while stack and nodes < max_nodes:
        prio, paths = stack.pop()
        nodes += 1
        last_pairs = {(h, lo) for lo, hs in prio.items() for h in hs}
        c = first_conflict(paths)
        if c is None:
            return PrioritySearchResult(dict(paths), True, counter["n"], last_pairs, nodes,
                                        counter["plans"], time.perf_counter() - clock, failures)
        children = []
        for hi, lo in (c, c[::-1]):
            if lo in closure_up(prio, hi):
                continue              # would make the order cyclic
            p2 = {k: set(v) for k, v in prio.items()}
            p2.setdefault(lo, set()).add(hi)
            q2 = dict(paths)
            if update(p2, q2, lo):
                cost = sum(t.t_end for t in q2.values())
                children.append((cost, p2, q2))
        # depth first, the cheaper child first
        for _, p2, q2 in sorted(children, key=lambda x: -x[0]):
            stack.append((p2, q2))
    return PrioritySearchResult({}, False, counter["n"], last_pairs, nodes, counter["plans"],
                                time.perf_counter() - clock, failures)
