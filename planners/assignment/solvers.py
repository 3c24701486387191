"""Exact backends for one sub-problem: OR-Tools CP-SAT and HiGHS (highspy).

Both take a :class:`rfp_twin.planners.assignment.problem.SubProblem` and return a
:class:`Solution`: which local candidates are taken, the objective, the best bound the
solver proved, and a status: ``optimal``, ``feasible`` (stopped at the time limit with a
solution) or ``infeasible``. CP-SAT needs integer objective coefficients: weights that
are not all integers are scaled by :data:`CPSAT_SCALE` and rounded (the reported
objective is the true weight sum of the chosen poses; the bound is scaled back).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from rfp_twin.planners.assignment.problem import EQ, GE, LE, SubProblem

SOLVERS = ("cpsat", "highs")
#: Objective scale of CP-SAT for non-integer weights.
CPSAT_SCALE = 1000.0


@dataclass(frozen=True)
class Solution:
    """x : (v,) bool taken candidates (local); objective, bound : weight sums;
    status : optimal | feasible | infeasible; seconds : wall time of the solve."""

    x: np.ndarray
    objective: float
    bound: float
    status: str
    seconds: float


def solve(sub: SubProblem, solver: str, *, time_limit_s: float, workers: int = 2,
          hint: np.ndarray | None = None) -> Solution:
    """Solve ``sub`` with ``solver`` (:data:`SOLVERS`); ``hint`` (v,) bool a feasible
    start (a hint for CP-SAT; HiGHS takes none, see :func:`solve_highs`)."""
    if solver == "cpsat":
        return solve_cpsat(sub, time_limit_s=time_limit_s, workers=workers, hint=hint)
    return solve_highs(sub, time_limit_s=time_limit_s)


def solve_cpsat(sub: SubProblem, *, time_limit_s: float, workers: int = 2,
                hint: np.ndarray | None = None) -> Solution:
    """CP-SAT: one Boolean per candidate, ExactlyOne / AtMostOne / linear >= rows."""
    from ortools.sat.python import cp_model

    t0 = time.perf_counter()
    w = sub.weight
    integral = bool(np.all(w == np.round(w)))
    scale = 1.0 if integral else CPSAT_SCALE
    coef = np.round(w * scale).astype(np.int64)
    m = cp_model.CpModel()
    x = [m.new_bool_var(f"x{k}") for k in range(w.size)]
    rows = sub.rows
    ptr, idx = rows.ptr, rows.idx.tolist()
    for r in range(rows.n_rows):
        lits = [x[k] for k in idx[ptr[r]:ptr[r + 1]]]
        kind = rows.kind[r]
        if kind == EQ:
            m.add_exactly_one(lits)
        elif kind == LE:
            m.add_at_most_one(lits)
        else:
            m.add(sum(lits) >= int(np.ceil(rows.lo[r])))
    nz = np.flatnonzero(coef)
    m.maximize(cp_model.LinearExpr.weighted_sum([x[k] for k in nz], coef[nz].tolist()))
    if hint is not None:
        for k in range(w.size):
            m.add_hint(x[k], bool(hint[k]))
    s = cp_model.CpSolver()
    s.parameters.max_time_in_seconds = float(time_limit_s)
    s.parameters.num_workers = int(workers)
    st = s.solve(m)
    secs = time.perf_counter() - t0
    if st in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        xv = np.array([s.boolean_value(v) for v in x], dtype=bool)
        obj = float(w[xv].sum())
        bound = float(s.best_objective_bound) / scale
        status = "optimal" if st == cp_model.OPTIMAL else "feasible"
        return Solution(xv, obj, max(bound, obj) if status == "optimal" else bound, status, secs)
    if st == cp_model.INFEASIBLE:
        return Solution(np.zeros(w.size, dtype=bool), np.nan, np.nan, "infeasible", secs)
    return Solution(np.zeros(w.size, dtype=bool), np.nan, float(s.best_objective_bound) / scale,
                    "unknown", secs)


def _new_highs():
    """A quiet ``highspy.Highs`` (its first construction in a process prints a banner on
    the C-level stdout, which is silenced here)."""
    import os
    import sys

    import highspy

    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            h = highspy.Highs()
    finally:
        os.dup2(saved, 1)
        os.close(saved)
    h.setOptionValue("output_flag", False)
    return h


def solve_highs(sub: SubProblem, *, time_limit_s: float, relax: bool = False) -> Solution:
    """HiGHS branch-and-cut (highspy), one thread; ``relax``: the linear relaxation only
    (its optimum is a bound; ``x`` then holds the fractional values > 0.5).

    No starting solution is passed: with one set (``Highs.setSolution``), HiGHS 1.16 was
    seen to report ``Optimal`` with a dual bound above the solution it returned (the
    start), so the greedy poses are not handed to it."""
    import highspy

    t0 = time.perf_counter()
    rows = sub.rows
    w = sub.weight
    v = w.size
    lp = highspy.HighsLp()
    lp.num_col_ = v
    lp.num_row_ = rows.n_rows
    lp.col_cost_ = w.astype(np.float64)
    lp.col_lower_ = np.zeros(v)
    lp.col_upper_ = np.ones(v)
    lp.row_lower_ = np.where(rows.kind == LE, -highspy.kHighsInf, rows.lo)
    lp.row_upper_ = np.where(rows.kind == GE, highspy.kHighsInf, rows.hi)
    lp.sense_ = highspy.ObjSense.kMaximize
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.start_ = rows.ptr.astype(np.int32)
    lp.a_matrix_.index_ = rows.idx.astype(np.int32)
    lp.a_matrix_.value_ = np.ones(rows.idx.size)
    lp.a_matrix_.num_col_ = v
    lp.a_matrix_.num_row_ = rows.n_rows
    if not relax:
        lp.integrality_ = [highspy.HighsVarType.kInteger] * v
    h = _new_highs()
    h.setOptionValue("time_limit", float(time_limit_s))
    h.setOptionValue("mip_rel_gap", 0.0)
    h.setOptionValue("threads", 1)
    h.passModel(lp)
    h.run()
    secs = time.perf_counter() - t0
    status = h.getModelStatus()
    ms = highspy.HighsModelStatus
    info = h.getInfo()
    if status == ms.kInfeasible:
        return Solution(np.zeros(v, dtype=bool), np.nan, np.nan, "infeasible", secs)
    x = np.asarray(h.getSolution().col_value, dtype=np.float64)
    if relax:
        obj = float(info.objective_function_value)
        return Solution(x > 0.5, obj, obj, "relaxed", secs)
    if x.size != v or info.primal_solution_status == 0:
        return Solution(np.zeros(v, dtype=bool), np.nan, float(info.mip_dual_bound), "unknown",
                        secs)
    xv = x > 0.5
    obj = float(w[xv].sum())
    bound = float(info.mip_dual_bound)
    if not np.isfinite(bound):
        bound = float(w.sum())
    optimal = status == ms.kOptimal
    return Solution(xv, obj, max(bound, obj) if optimal else max(bound, obj),
                    "optimal" if optimal else "feasible", secs)
