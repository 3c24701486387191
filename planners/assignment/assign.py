"""Collision-aware fiber assignment: catalogue + array -> one pose per robot.

:func:`assign` picks at most one target per robot and each target at most once, so that
no two final poses collide (robot pairs and obstacles, at each robot's buffer plus a
margin), with at least a given number of sky and standard fibers in each region of the
plane, maximising the sum of the priorities of the targets taken. Robots left without a
target get a parking pose, which the planner treats as a target: the fold, or with
``AssignSettings.parking = "clear"`` the fold or one of its alpha turns, chosen in the
same program (a parking pose collides like any other; the fold is preferred by a small
penalty on the others, :mod:`rfp_twin.planners.assignment.candidates`).

Methods (``AssignSettings.solver``):

- ``cpsat`` / ``highs``: the exact program of :mod:`rfp_twin.planners.assignment.problem`,
  split into independent components, each solved by OR-Tools CP-SAT or HiGHS (CP-SAT
  with the greedy solution as a hint); the result is proven optimal unless the time
  limit stops a component, and its bound is reported either way. A component of more
  than :data:`MAX_EXACT_ROBOTS` robots is not solved whole: its greedy poses are improved
  window by window, each window solved exactly by HiGHS
  (:mod:`rfp_twin.planners.assignment.windows`); its bound is then each robot's best
  weight, summed.
- ``greedy``: the heuristic of :mod:`rfp_twin.planners.assignment.greedy` (greedy by
  priority + local improvement); bound: each robot's best candidate, summed (conflicts
  and shared targets ignored), capped by the catalogue's reachable targets.
- ``auto``: :data:`DEFAULT_EXACT` (HiGHS, chosen by benchmarks/bench_assign.py).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from rfp_twin.models.catalogue import KINDS, SKY, STANDARD, Catalogue
from rfp_twin.models.errors import AssignmentError
from rfp_twin.planners.assignment.candidates import (ARMS, DEFAULT_PARKING, PARKING_MODES,
                                                     PARKING_PENALTY, Candidates,
                                                     build_candidates, subset)
from rfp_twin.planners.assignment.conflicts import (conflict_cliques, conflict_degrees,
                                                    conflict_pairs, neighbour_pairs,
                                                    symmetric_csr)
from rfp_twin.planners.assignment.dominance import undominated
from rfp_twin.planners.assignment.greedy import greedy_assign
from rfp_twin.planners.assignment.problem import Problem, Rows
from rfp_twin.planners.assignment.solvers import SOLVERS, solve
from rfp_twin.planners.assignment.windows import improve_windows

METHODS = ("auto", "greedy") + SOLVERS
#: Components of more robots than this are not solved whole: the greedy poses are
#: improved window by window (:mod:`rfp_twin.planners.assignment.windows`).
MAX_EXACT_ROBOTS = 2000
#: The exact solver used by ``auto`` (chosen by benchmarks/bench_assign.py).
DEFAULT_EXACT = "highs"


@dataclass(frozen=True)
class Quotas:
    """Minimum calibration fibers per region: the plane is cut into ``sectors`` equal
    angular sectors about the centre of the robot bases (sector 0 starts at +x and they
    go counter-clockwise); each needs at least ``sky`` sky and ``standard`` standard
    targets assigned."""

    sky: int = 0
    standard: int = 0
    sectors: int = 1

    def __post_init__(self) -> None:
        for name in ("sky", "standard"):
            v = getattr(self, name)
            if not (isinstance(v, (int, np.integer)) and 0 <= v <= 10_000):
                raise AssignmentError(f"quota field {name!r} = {v!r}; allowed: an integer in "
                                      "[0, 10000] per region")
        if not (isinstance(self.sectors, (int, np.integer)) and 1 <= self.sectors <= 360):
            raise AssignmentError(f"quota field 'sectors' = {self.sectors!r}; allowed: an "
                                  "integer in [1, 360]")

    @property
    def active(self) -> bool:
        return self.sky > 0 or self.standard > 0


@dataclass(frozen=True)
class AssignSettings:
    """How to assign.

    solver : auto | greedy | cpsat | highs (module docstring)
    time_limit_s : wall-clock budget of the exact solves, s
    workers : solver threads
    arms : arm solutions that are candidates (right, left). Default right only: the
        stepwise planners fold right-armed poses with ease, while left-armed ones (beta in
        (180, 360)) cost them dearly (benchmarks/RESULTS.md, fiber assignment)
    margin_mm : clearance beyond the collision rule between final poses (and obstacles)
    quotas : minimum sky / standard fibers per region
    forbidden : (robot id, target id) pairs that may not be assigned
    fixed : ((robot id, alpha, beta), ...) robots that do not move (offline): they keep
        that pose, which the others' poses must clear
    max_sweeps : local-improvement sweeps of the heuristic
    parking : fold | clear: the parking poses of robots without a target (module docstring)
    """

    solver: str = "auto"
    time_limit_s: float = 10.0
    workers: int = 2
    arms: tuple[str, ...] = ("right",)
    margin_mm: float = 0.0
    quotas: Quotas = field(default_factory=Quotas)
    forbidden: frozenset = frozenset()
    fixed: tuple = ()
    max_sweeps: int = 20
    parking: str = DEFAULT_PARKING

    def __post_init__(self) -> None:
        if self.parking not in PARKING_MODES:
            raise AssignmentError(f"--parking {self.parking!r}; allowed: "
                                  f"{', '.join(PARKING_MODES)}")
        if self.solver not in METHODS:
            raise AssignmentError(f"--solver {self.solver!r}; allowed: {', '.join(METHODS)}")
        bad = [a for a in self.arms if a not in ARMS]
        if bad or not self.arms:
            raise AssignmentError(f"--arms {','.join(self.arms)!r}; allowed: right, left or both")
        if not (np.isfinite(self.time_limit_s) and self.time_limit_s > 0):
            raise AssignmentError(f"--time-limit {self.time_limit_s!r}; allowed: > 0 s")
        if not (np.isfinite(self.margin_mm) and self.margin_mm >= 0):
            raise AssignmentError(f"margin {self.margin_mm!r} mm; allowed: >= 0")


@dataclass
class Assignment:
    """One pose per robot (n robots, layout order).

    robot_ids : (n,) int64; target : (n,) int64 catalogue row, -1 parked;
    target_ids : (n,) int64 catalogue id, -1 parked; angles : (n, 2) deg (the planner's
    targets); arm : (n,) int8 (0 right, 1 left, -1 parked); slot : (n,) fiber slot
    (0 BOSS / generic, 1 APOGEE, -1 parked); kind : (n,) int8 catalogue kind, -1 parked.
    objective, bound : priority sums; status : optimal | feasible | heuristic;
    stats : counts and seconds for the report.
    """

    robot_ids: np.ndarray
    target: np.ndarray
    target_ids: np.ndarray
    angles: np.ndarray
    arm: np.ndarray
    slot: np.ndarray
    kind: np.ndarray
    objective: float
    bound: float
    status: str
    solver: str
    stats: dict

    @property
    def gap(self) -> float:
        """(bound - objective) / bound; 0 when the bound is 0."""
        return 0.0 if self.bound <= 0 else max(0.0, (self.bound - self.objective) / self.bound)

    @property
    def n_assigned(self) -> int:
        return int(np.count_nonzero(self.target >= 0))

    def counts(self) -> dict[str, int]:
        """Robots per kind of pose, {science, sky, standard, parked, parked_off_fold} (the
        last: parked robots at a clear parking pose, not the fold)."""
        out = {name: int(np.count_nonzero(self.kind == k)) for k, name in enumerate(KINDS)}
        out["parked"] = int(np.count_nonzero(self.target < 0))
        out["parked_off_fold"] = int(self.stats.get("parked_off_fold", 0))
        return out


def _regions(geom, xy: np.ndarray, sectors: int) -> np.ndarray:
    """(t,) sector index of each point about the centre of the robot bases."""
    c = geom.base_xy.mean(axis=0) if geom.n_robots else np.zeros(2)
    ang = np.arctan2(xy[:, 1] - c[1], xy[:, 0] - c[0]) % (2 * np.pi)
    return np.minimum((ang / (2 * np.pi / sectors)).astype(np.int64), sectors - 1)


def _quota_rows(geom, cands: Candidates, cat: Catalogue, quotas: Quotas):
    """[(candidate indices, minimum, description)] of every active quota."""
    if not quotas.active:
        return []
    real = cands.target >= 0
    region = np.full(cands.n, -1, dtype=np.int64)
    region[real] = _regions(geom, cat.xy[cands.target[real]], quotas.sectors)
    kind = np.full(cands.n, -1, dtype=np.int64)
    kind[real] = cat.kind[cands.target[real]]
    out = []
    width = 360.0 / quotas.sectors
    for k, minimum in ((SKY, quotas.sky), (STANDARD, quotas.standard)):
        if minimum <= 0:
            continue
        for s in range(quotas.sectors):
            members = np.flatnonzero((kind == k) & (region == s))
            where = (f"region {s} of {quotas.sectors} (sector {s * width:g}-{(s + 1) * width:g} "
                     "deg)" if quotas.sectors > 1 else "the whole plane")
            out.append((members, int(minimum), f"{KINDS[k]} quota in {where}"))
    return out


def _finish(geom, cat: Catalogue, cands: Candidates, chosen: np.ndarray, bound: float,
            status: str, solver: str, stats: dict) -> Assignment:
    tgt = cands.target[chosen]
    on = tgt >= 0
    kind = np.full(tgt.size, -1, dtype=np.int8)
    kind[on] = cat.kind[tgt[on]]
    ids = np.full(tgt.size, -1, dtype=np.int64)
    ids[on] = cat.ids[tgt[on]]
    objective = float(cands.weight[chosen][on].sum())     # parking penalties left out
    stats["parked_off_fold"] = int(np.count_nonzero(~on & (chosen != cands.parking)))
    return Assignment(robot_ids=geom.robot_ids.copy(), target=tgt, target_ids=ids,
                      angles=cands.angles[chosen].copy(), arm=cands.arm[chosen].copy(),
                      slot=cands.slot[chosen].copy(), kind=kind, objective=objective,
                      bound=max(bound, objective), status=status, solver=solver, stats=stats)


def relaxed_bound(cands: Candidates, n_targets: int) -> float:
    """A bound no assignment exceeds: each robot's best weight, summed, and no more than the
    sum of the best weights of as many distinct reachable targets as robots that reach one."""
    best = np.maximum.reduceat(cands.weight, cands.ptr[:-1]) if cands.n else np.zeros(0)
    robots_bound = float(best.sum())
    real = cands.target >= 0
    tw = np.zeros(max(n_targets, 1))
    np.maximum.at(tw, cands.target[real], cands.weight[real])
    k = int(np.count_nonzero(best > 0))
    targets_bound = float(np.sort(tw)[::-1][:k].sum())
    return min(robots_bound, targets_bound)


def assign(geom, catalogue: Catalogue, settings: AssignSettings | None = None) -> Assignment:
    """Assign ``catalogue`` to the robots of ``geom`` (module docstring).

    Raises
    ------
    AssignmentError
        No target of a non-empty catalogue within reach of any robot; a quota that no
        assignment meets (naming the region and the best count reachable).
    """
    s = settings or AssignSettings()
    t0 = time.perf_counter()
    cands = build_candidates(geom, catalogue, margin_mm=s.margin_mm, arms=s.arms,
                             forbidden=set(s.forbidden) if s.forbidden else None,
                             fixed={int(r): (float(a), float(b)) for r, a, b in s.fixed},
                             parking=s.parking)
    n_real = int(np.count_nonzero(cands.target >= 0))
    if catalogue.n_targets and n_real == 0:
        raise AssignmentError(f"{catalogue.source}: none of its {catalogue.n_targets} targets is "
                              "within reach of a robot (with a fiber it accepts, clear of "
                              "obstacles); allowed: targets on the array's patrol areas")
    t_cand = time.perf_counter()
    pairs = neighbour_pairs(geom, s.margin_mm)
    nbr_ptr, nbr_idx = symmetric_csr(pairs[:, 0], pairs[:, 1], geom.n_robots)
    quota_rows = _quota_rows(geom, cands, catalogue, s.quotas)
    for members, minimum, what in quota_rows:
        if members.size < minimum:
            raise AssignmentError(f"{what}: needs {minimum}; at most {members.size} reachable "
                                  f"({members.size} candidate poses); allowed: a quota <= the "
                                  "best count reachable")
    allowed = np.ones(cands.n, dtype=bool)
    gain = np.maximum(cands.weight, 0.0)        # the targets' weights (no parking penalty)
    slack = PARKING_PENALTY if s.parking == "clear" else 0.0
    degree = conflict_degrees(cands, pairs, geom.buffer, s.margin_mm)
    greedy_chosen, sweeps = greedy_assign(cands, catalogue.n_targets, nbr_ptr, nbr_idx,
                                          geom.buffer, s.margin_mm, allowed=allowed,
                                          degree=degree,
                                          quotas=[(m, q) for m, q, _ in quota_rows],
                                          max_sweeps=s.max_sweeps)
    t_greedy = time.perf_counter()
    stats = {"n_robots": geom.n_robots, "n_targets": catalogue.n_targets,
             "n_candidates": n_real, "n_neighbour_pairs": int(pairs.shape[0]),
             "greedy_objective": float(gain[greedy_chosen].sum()),
             "greedy_sweeps": sweeps,
             "seconds": {"candidates": t_cand - t0, "greedy": t_greedy - t_cand}}
    method = DEFAULT_EXACT if s.solver == "auto" else s.solver
    easy = relaxed_bound(cands, catalogue.n_targets)
    if not quota_rows and stats["greedy_objective"] >= easy:
        # every robot has its best weight (or every reachable target is taken): optimal
        stats["seconds"]["total"] = time.perf_counter() - t0
        return _finish(geom, catalogue, cands, greedy_chosen, easy, "optimal", "greedy", stats)
    if method == "greedy":
        if quota_rows:
            _check_greedy_quotas(cands, greedy_chosen, quota_rows)
        stats["seconds"]["total"] = time.perf_counter() - t0
        return _finish(geom, catalogue, cands, greedy_chosen, easy, "heuristic", "greedy", stats)

    a, b = conflict_pairs(cands, pairs, geom.buffer, s.margin_mm)
    # presolve: poses another pose of the same robot dominates never need to be taken
    group = np.full(cands.n, -1, dtype=np.int64)
    for q, (members, _, _) in enumerate(quota_rows):
        group[members] = q
    red, sel = subset(cands, undominated(cands, a, b, group))
    new_index = np.full(cands.n, -1, dtype=np.int64)
    new_index[sel] = np.arange(sel.size)
    both = (new_index[a] >= 0) & (new_index[b] >= 0)
    cp, ci = conflict_cliques(new_index[a[both]], new_index[b[both]], red.robot)
    red_quotas = [(new_index[m][new_index[m] >= 0], q, what) for m, q, what in quota_rows]
    problem = Problem.build(red, cp, ci, [(m, q) for m, q, _ in red_quotas])
    subs = problem.split()
    t_model = time.perf_counter()
    chosen = greedy_chosen.copy()
    hint_x = np.zeros(cands.n, dtype=bool)
    hint_x[greedy_chosen] = True
    hint_red = hint_x[sel]
    robot_best = np.maximum.reduceat(cands.weight, cands.ptr[:-1])
    bound = 0.0
    all_optimal = True
    n_solved = 0
    largest = 0
    for sub in subs:
        if sub.n_robots == 1 and not sub.has_quota:
            best = sub.cands[int(np.argmax(sub.weight))]
            chosen[problem.robot[best]] = sel[best]
            bound += float(sub.weight.max())
            continue
        robots = np.unique(problem.robot[sub.cands])
        easy = float(robot_best[robots].sum())
        if not sub.has_quota and gain[greedy_chosen[robots]].sum() >= easy:
            bound += easy       # the greedy poses give every robot its best weight: optimal
            continue
        n_solved += 1
        largest = max(largest, sub.n_robots)
        left = max(0.05, s.time_limit_s - (time.perf_counter() - t_model))
        if sub.n_robots > MAX_EXACT_ROBOTS and not sub.has_quota:
            # too large to solve whole: the greedy poses improved window by window
            got = improve_windows(cands, chosen, geom.base_xy, catalogue.n_targets, a, b,
                                  robots=robots, time_limit_s=left)
            for k, name in (("windows", "windows_solved"), ("improved", "windows_improved")):
                stats[name] = stats.get(name, 0) + got[k]
            all_optimal = False
            bound += easy
            continue
        sol = solve(sub, method, time_limit_s=left, workers=s.workers, hint=hint_red[sub.cands])
        if sol.status == "infeasible":
            _explain_quota(geom, red, problem, red_quotas, method, s)
        if sol.status not in ("optimal", "feasible"):
            # no solution in time: keep the greedy poses of this component
            all_optimal = False
            bound += min(sol.bound, easy) if np.isfinite(sol.bound) else easy
            continue
        taken = sub.cands[sol.x]
        chosen[problem.robot[taken]] = sel[taken]
        got = float(gain[sel[taken]].sum())
        # the solver's bound counts the parking penalties; a target-sum optimum is the
        # solution's (penalties far below a priority), a stopped solve's bound gains them back
        bound += (max(sol.bound, got) if sol.status == "optimal" else
                  min(sol.bound + slack * sub.n_robots, easy))
        all_optimal &= sol.status == "optimal"
    stats["n_candidates_presolved"] = int(sel.size - geom.n_robots)
    t_solve = time.perf_counter()
    stats.update({"n_conflict_pairs": int(a.size), "n_rows": problem.rows.n_rows,
                  "n_components": len(subs), "n_components_solved": n_solved,
                  "largest_component_robots": largest})
    stats["seconds"].update({"model": t_model - t_greedy, "solve": t_solve - t_model,
                             "total": t_solve - t0})
    return _finish(geom, catalogue, cands, chosen, bound,
                   "optimal" if all_optimal else "feasible", method, stats)


def _check_greedy_quotas(cands: Candidates, chosen: np.ndarray, quota_rows) -> None:
    taken = np.zeros(cands.n, dtype=bool)
    taken[chosen] = True
    for members, minimum, what in quota_rows:
        got = int(np.count_nonzero(taken[members]))
        if got < minimum:
            raise AssignmentError(f"{what}: needs {minimum}; the heuristic reached {got}; "
                                  "allowed: a quota it meets, or --solver cpsat|highs (exact)")


def _explain_quota(geom, cands: Candidates, problem: Problem, quota_rows, method: str,
                   s: AssignSettings) -> None:
    """Raise AssignmentError naming the first quota whose best reachable count (each
    quota alone, by the exact solver) is below its minimum, or saying they conflict."""
    for members, minimum, what in quota_rows:
        w = np.zeros(cands.n)
        w[members] = 1.0
        alone = Problem(problem.robot, w, _without_quotas(problem), problem.n_robots, 0)
        best = 0.0
        for sub in alone.split():
            if sub.weight.max(initial=0.0) <= 0:
                continue
            sol = solve(sub, method, time_limit_s=s.time_limit_s, workers=s.workers)
            best += sol.objective if np.isfinite(sol.objective) else 0.0
        if best < minimum:
            raise AssignmentError(f"{what}: needs {minimum}; the best count reachable is "
                                  f"{int(round(best))}; allowed: a quota <= {int(round(best))}")
    raise AssignmentError(f"quotas {', '.join(q[2] for q in quota_rows)}: each is reachable "
                          "alone but not all together; allowed: lower quotas")


def _without_quotas(problem: Problem) -> Rows:
    """``problem``'s rows without its quota rows (the last ``n_quota``)."""
    r = problem.rows
    keep = r.n_rows - problem.n_quota
    end = int(r.ptr[keep])
    return Rows(r.ptr[:keep + 1], r.idx[:end], r.lo[:keep], r.hi[:keep], r.kind[:keep])
