"""Deadlock resolution that keeps targets: Sabater's state-time search for alpha/beta robots.

The reverse GC/MC planner (:mod:`rfp_twin.planners.stepwise`) sometimes leaves a group of robots
deadlocked (Sayres 2021 Sect. 5.2). Instead of replacing one target of the group, this
module re-plans the group with the roadmap / state-time planner of
:mod:`rfp_twin.planners.roadmap` (Sabater 2018), in the planner's frame (reverse: each
deadlocked robot goes from its target, at step 0, to the folded state):

* every robot outside the group follows its existing stepwise path, a **moving
  obstacle** on the planner's step clock (after its last breakpoint it stays put);
  fiducials, offline robots and the joint limits are **static** (``forbidden``);
* the group's robots are planned one at a time, each against the robots above it in a
  priority order (Sabater's Algorithm 1), and the order itself is searched
  (:func:`rfp_twin.planners.roadmap.priority_search`): where two trajectories conflict, one
  robot yields to the other and is planned again;
* a deadlocked robot may keep, for as long as it likes, the stepwise motion it made
  before it got stuck (its lead-in, :attr:`rfp_twin.planners.roadmap.Arm.lead_in`); if that
  fails, the group is searched again from step 0;
* a robot that finds no trajectory at all **recruits** the neighbours that blocked it
  most (robots that had reached their destination): they join the group below it and
  may leave their stepwise paths at any time to make way (``max_recruits`` at most);
* each robot's roadmap (25 x 25 grid over the joint limits, random edges, the
  start/goal corners) also holds a "retract beta to 180 deg, turn alpha, go to the
  goal" path (:meth:`.world.AlphaBetaWorld.via`): a beta arm folded over its own axis sweeps
  the smallest disk when alpha turns;
* the single-robot search is Sabater's state-time graph explored one time layer at a
  time (``search="sweep"``, earliest arrival; ``"dfs"`` is the paper's depth-first
  search); start-stop cycles are unlimited: stepwise plans stop and restart freely and
  post-processing smooths them.

Recruiting the blocking neighbours and searching over priorities each raise the share
of groups resolved over Sabater's fixed order (benchmarks/HISTORY.md, "Code comments",
under the module's former path planners/resolve_search/resolve.py). Whole-plan figures, with replacement where
the search fails: benchmarks/RESULTS.md.

The collision test on the step clock, and why the merged plan stays collision-free:
:mod:`rfp_twin.planners.roadmap.alpha_beta.world`.

Units: mm and degrees; the search runs on the step clock (time unit = one planner step,
``step_s`` seconds).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.planners.deadlocks.search.trim import trim_tails
from rfp_twin.planners.roadmap import Arm, ArmTrajectory, priority_search
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
from rfp_twin.planners.roadmap.alpha_beta.settings import SearchResolveSettings
from rfp_twin.planners.roadmap.alpha_beta.world import AlphaBetaWorld


@dataclass
class GroupResult:
    """Outcome of one deadlocked group.

    Attributes
    ----------
    group : (g,) robot indices deadlocked together
    members : robot indices re-planned (the group, plus the neighbours it recruited)
    success : bool
    orders_tried : int, nodes of the search over priorities (both starts)
    seconds : float
    hardest : robot index of the group that most often found no trajectory (-1: none)
    """

    group: np.ndarray
    members: np.ndarray
    success: bool
    orders_tried: int
    seconds: float
    hardest: int = -1


@dataclass
class SearchOutcome:
    """What :func:`resolve_groups` did.

    Attributes
    ----------
    paths : PathSet with the paths of every resolved group replaced (planning frame)
    n_steps : int, length of the plan on the step clock: its last motion
    groups : list of GroupResult, in the order processed
    seconds : float, wall time of the search
    trimmed : robot indices whose detours after arriving were cut (:func:`trim_tails`)
    """

    paths: PathSet
    n_steps: int
    groups: list = field(default_factory=list)
    seconds: float = 0.0
    trimmed: list = field(default_factory=list)

    @property
    def failed(self) -> list[np.ndarray]:
        """The groups the search could not resolve."""
        return [g.group for g in self.groups if not g.success]

    @property
    def failed_hardest(self) -> list[int]:
        """For each failed group, the robot that most often found no trajectory (the one
        to give a new target), or -1."""
        return [g.hardest for g in self.groups if not g.success]

    @property
    def resolved_robots(self) -> np.ndarray:
        """Indices of the deadlocked robots whose groups the search resolved."""
        ok = [g.group for g in self.groups if g.success]
        return np.concatenate(ok) if ok else np.zeros(0, dtype=np.int64)


def _traj_from_path(steps: np.ndarray, angles: np.ndarray) -> ArmTrajectory:
    return ArmTrajectory(np.asarray(steps, dtype=np.float64), np.asarray(angles, dtype=np.float64),
                         np.asarray(angles, dtype=np.float64)[[0, -1]], 0, 0, 0)


def _lead_in_end(world: AlphaBetaWorld, i: int, deadlocked: np.ndarray) -> float:
    """Where robot i's lead-in ends: its last motion, or the last motion of its
    neighbours that are not deadlocked if that is earlier. A Markov run that deadlocks
    goes on to its step limit and its stuck robots step about all that time; once their
    neighbours have stopped that motion leads nowhere, and keeping it would only delay
    the fold."""
    settle = max((world.paths.motion_end(int(j)) for j in world.neighbours(i)
                  if not deadlocked[int(j)]), default=0.0)
    return min(world.paths.motion_end(i), settle)


def search_group(world: AlphaBetaWorld, group: np.ndarray, start: np.ndarray, dest: np.ndarray,
                 movable: np.ndarray, deadlocked: np.ndarray, settings: SearchResolveSettings,
                 rng: np.random.Generator):
    """Re-plan one deadlocked group by a search over priorities (Sabater's planner per robot).

    Uses :func:`rfp_twin.planners.roadmap.priority_search`: each robot is planned against the
    robots above it only; pairwise conflicts branch on who yields. A robot that finds
    no trajectory recruits the non-deadlocked neighbours it met most (two at a time,
    ``settings.max_recruits`` in all): they join below it, free to leave their stepwise
    paths (their lead-in) to make way. Two starts are tried: (1) each deadlocked robot
    may keep, for as long as it likes, the stepwise motion it made before it got stuck;
    (2) it is searched from step 0 (the other way round with ``settings.step0_first``).

    Returns (success, robot indices re-planned, {robot: (steps, angles)}, tree nodes,
    the deadlocked robot that most often found no trajectory or -1).
    """
    rs = settings.roadmap_settings(world.step_deg)
    nodes = 0
    agents: list[int] = []
    fails: dict[int, int] = {}
    for keep_prefix in ((False, True) if settings.step0_first else (True, False)):
        agents = [int(i) for i in group]
        lead = {}
        if keep_prefix:
            lead = {i: world.paths.prefix(i, _lead_in_end(world, i, deadlocked)) for i in agents}

        def make_arm(a: int, higher: dict[int, ArmTrajectory], arms: frozenset) -> Arm:
            i = agents[a]
            override = {agents[h]: (tr.times, tr.configs, None) for h, tr in higher.items()}
            # robots of this search node not above i are ignored; robots recruited in
            # another branch are not in this node: their current paths are obstacles
            ignore = frozenset(agents[b] for b in arms if b != a and b not in higher)
            arm = world.arm(i, start[i], dest[i], 0.0, ignore, override)
            if i in lead and lead[i][0][-1] > 0:
                # it may keep its stepwise motion for a while and leave it at any time
                arm = replace(arm, lead_in=lead[i])
            return arm

        def conflict(a: int, tra: ArmTrajectory, b: int, trb: ArmTrajectory) -> bool:
            return world.conflict(agents[a], tra, agents[b], trb)

        def recruit(a: int, limit: int) -> list[tuple[int, ArmTrajectory]]:
            i = agents[a]
            new = [j for j in world.blockers(i, exclude=agents)
                   if movable[j] and not deadlocked[j]][:min(2, limit)]
            out = []
            for j in new:
                agents.append(j)
                lead[j] = world.paths.prefix(j, world.paths.motion_end(j))
                out.append((len(agents) - 1, _traj_from_path(world.paths.steps[j],
                                                            world.paths.angles[j])))
            return out

        res = priority_search(len(agents), make_arm, conflict, rs, rng, recruit=recruit,
                              max_nodes=settings.priority_nodes,
                              max_recruits=settings.max_recruits)
        nodes += res.nodes
        for a, c in res.failures.items():
            fails[agents[a]] = fails.get(agents[a], 0) + c
        if res.success:
            paths = {agents[a]: (tr.times, tr.configs) for a, tr in res.trajectories.items()}
            return True, [agents[a] for a in sorted(res.trajectories)], paths, nodes, -1
    in_group = {int(i): fails.get(int(i), 0) for i in group}
    hardest = max(in_group, key=lambda i: in_group[i]) if any(in_group.values()) else -1
    return False, agents, {}, nodes, hardest


def resolve_groups(geom: ArrayGeometry, paths: PathSet, n_steps: int, groups: list[np.ndarray],
                   start: np.ndarray, dest: np.ndarray, movable: np.ndarray, md: float,
                   step_deg: float, settings: SearchResolveSettings,
                   rng: np.random.Generator, memo: dict | None = None) -> SearchOutcome:
    """Re-plan each deadlocked group by prioritized state-time search, keeping targets.

    Parameters
    ----------
    geom : ArrayGeometry
    paths : PathSet, the stepwise run's paths (planning frame: start -> dest)
    n_steps : int, length of that run in steps
    groups : deadlocked groups (robot index arrays), e.g. from ``deadlocked_groups``
    start, dest : (n, 2) deg, every robot's start and destination in the planning frame
    movable : (n,) bool, False for offline robots
    md : float, step-rule margin MD, mm; step_deg : float, planner step, deg
    settings : SearchResolveSettings; rng : numpy Generator
    memo : dict or None, kept by the caller across planning rounds: a group whose
        robots and surroundings (the paths, up to their last motion, of the robots it
        re-planned and of their Eq. 4 neighbours) are the same as in an earlier round
        gets that round's result again without a search (after a target replacement
        the greedy planner re-plans everything, mostly to the same paths)

    Returns
    -------
    SearchOutcome. Groups are processed one after the other; a resolved group's new
    paths are moving obstacles for the groups after it. A group that fails keeps its
    stepwise paths (still deadlocked). Non-deadlocked neighbours that block a robot may
    be re-planned too (recruited, ``settings.max_recruits``).
    """
    clock = time.perf_counter()
    paths = PathSet(list(paths.steps), list(paths.angles))
    world = AlphaBetaWorld(geom, paths, movable, md, step_deg)
    deadlocked = np.zeros(geom.n_robots, dtype=bool)
    for g in groups:
        deadlocked[g] = True
    out = SearchOutcome(paths, int(n_steps))
    out.trimmed = trim_tails(geom, paths, dest, deadlocked | ~np.asarray(movable, bool), md)
    def context(robots) -> dict[int, bytes]:
        near = set(int(i) for i in robots)
        for i in robots:
            near.update(int(j) for j in world.neighbours(int(i)))
        return {j: paths.signature(j) for j in near}

    for group in groups:
        t0 = time.perf_counter()
        key = tuple(sorted(int(i) for i in group))
        hit = None
        for entry in (memo or {}).get(key, []):
            if all(paths.signature(j) == sig for j, sig in entry[0].items()):
                hit = entry
                break
        if hit is not None:
            _, ok, members, new_paths, tried, hardest = hit
        else:
            ok, members, new_paths, tried, hardest = search_group(
                world, group, start, dest, movable, deadlocked, settings, rng)
            if memo is not None:
                ctx = context(members if ok else group)
                memo.setdefault(key, []).append((ctx, ok, members, new_paths, tried, hardest))
        if ok:
            for i, (st, an) in new_paths.items():
                paths.steps[i] = np.asarray(st, dtype=np.float64)
                paths.angles[i] = np.asarray(an, dtype=np.float64)
                out.n_steps = max(out.n_steps, int(math.ceil(float(st[-1]))))
        out.groups.append(GroupResult(np.asarray(group), np.asarray(members), ok, tried,
                                      time.perf_counter() - t0, int(hardest)))
    # the plan ends with its last motion (the run it came from may have gone on longer)
    last = max((paths.motion_end(i) for i in range(geom.n_robots)), default=0.0)
    out.n_steps = max(1, int(math.ceil(last)))
    out.seconds = time.perf_counter() - clock
    return out
