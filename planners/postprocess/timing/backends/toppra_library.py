"""The ``toppra`` timing backend: the library's TOPP-RA on exact constraints.

:func:`solve` hands one group's discretised problem (the gridpoints, ``q'`` at the
gridpoints, the constant ``q''`` of every interval, the per-joint limits) to the
``toppra`` library (0.6): its :class:`toppra.algorithm.TOPPRA` with the seidel solver
computes the controllable sets and the forward pass. The constraints are two
:class:`toppra.constraint.LinearConstraint` subclasses over precomputed arrays, so the
library solves *the same* discretised problem as the numba kernel
(:func:`rfp_twin.planners.postprocess.timing.kernel.topp_kernel`):

- :class:`IntervalVelocityBounds`: ``x_i <= v_k^2 / max(q'_k^2)`` over gridpoints
  ``i - 1, i, i + 1`` (the kernel's bound, which holds between gridpoints), and
  ``x_i <= sd_cap^2``;
- :class:`IntervalAccelerationRows`: on interval ``i``, ``|q'_k(s_i) u + q''_k x_i|
  <= a_k`` and ``|q'_k(s_{i+1}) u + q''_k x_{i+1}| <= a_k`` with ``x_{i+1} = x_i + 2
  delta_i u`` and ``q''_k`` the interval's own constant curvature. The joint
  acceleration is linear in ``s`` on the interval, so this bounds it everywhere.

Why the stock constraints failed, measured on the 500-robot SDSS-V layout (seed 0, 386
groups, 0 solved with ``JointVelocityConstraint`` / ``JointAccelerationConstraint``):
the seidel 2D LP (variables ``u``, ``x``, each boxed to +-1e8) walks each violated
constraint line ``a u + b x + c = 0`` with the *unnormalised* direction ``(-b, a)``
and bounds the line parameter by +-1e10. A smoothed axis has ``q'`` of 1e-5 to 1e-1
deg/step and ``q''`` up to about 5e-4 deg/step^2 (``s`` in plan steps; at the first
failing stage of seed 0's first group, ``q' = 6.8e-5``, ``q'' = 5.0e-4``), so
``|(-b, a)|`` is 1e-5 to 1e-3 and, when the LP walks such a line from its start at the
box corner (1e8, 1e8), the optimum lies some 3e11 line units away, beyond the bound;
the 1D subproblem then ends on that artificial bound,
which the solver reports as infeasible, and the backward pass stops with "The
controllable set at step [i / N] can't be computed". Which line is walked first depends
on the warm start (the previous stage's active constraints): the same stage solved cold
succeeds (checked against scipy's ``linprog`` and a line-by-line Python replica of the
solver). The failures therefore sit where an axis creeps or starts (smallest
coefficients), not where the problem is infeasible. Fixes here:

1. every acceleration row is divided by its norm ``hypot(a, b)`` (the solver's line
   parameter is then a distance in the (u, x) plane, at most ~1.5e8 < 1e10): on the
   386 groups of that fold, the same problems with the rows left unnormalised are
   solved for 1 group, with unit rows for all 386;
2. the path parameter is handed to the library as ``sigma = s / scale`` with ``scale =
   sd_cap / SEIDEL_SD_MAX``, so ``x`` stays below the solver's 1e8 box at the kernel's
   cap (1e5 steps/s, i.e. ``x`` up to 1e10 in steps) and the same ``sd_cap`` applies
   to both backends;
3. the acceleration rows use each interval's own ``q''`` at both of its ends (the
   library's ``Interpolation`` scheme takes ``q''(s_{i+1})``, i.e. the next interval's
   curvature where ``q''`` jumps at a knot, which under-constrains the interval).

With these the library and the kernel agree on every group to 2e-5 of the duration
(tests/planners/postprocess/timing/test_backends.py, benchmarks/RESULTS.md). The seidel solver is the only
one the installed wheel can use (the qpOASES, cvxpy and ECOS wrappers need packages
that are not installed).

:class:`RestToRestTOPPRA` skips the library's LP for the lower end of each
controllable set: from rest to rest with ``x >= 0`` that end is 0 (``x = u = 0`` is
admissible at every stage), which the LP returns anyway, and trims the library's
per-stage input checks of the forward pass: 35 % less time, the same laws.

:func:`solve_law` is the backend's entry point (:mod:`rfp_twin.planners.postprocess.timing.backends`): it
checks the library's ``x`` against the discretised constraints
(:func:`rfp_twin.planners.postprocess.timing.kernel.law_excess`) and turns it into a time law.

Units: degrees, seconds, plan steps.
"""
from __future__ import annotations

import math

import numpy as np
import toppra
import toppra.algorithm as algo
from toppra.constraint import DiscretizationType, LinearConstraint
from toppra.interpolator import AbstractGeometricPath

from rfp_twin.planners.postprocess.timing.backends import TimingProblem
from rfp_twin.planners.postprocess.timing.kernel import law_excess
from rfp_twin.planners.postprocess.timing.law import TimeLaw, law_times

__all__ = ["SEIDEL_SD_MAX", "TOPPRA_TOLERANCE", "GridPath", "IntervalVelocityBounds",
           "IntervalAccelerationRows", "RestToRestTOPPRA", "velocity_bounds", "solve",
           "solve_law"]

#: Largest path speed handed to the seidel solver, sigma units per s: x = sd^2 stays at
#: 2.5e7, below the solver's box on x (1e8).
SEIDEL_SD_MAX = 5.0e3
#: Largest relative excess of the library's law over the discretised constraints that a
#: uniform slow-down absorbs (more counts as no solution).
TOPPRA_TOLERANCE = 1e-3

toppra.setup_logging("ERROR")


class GridPath(AbstractGeometricPath):
    """A path of which the library needs only its interval and joint count.

    The constraints below carry precomputed derivatives, so nothing evaluates the path;
    calling it raises.
    """

    def __init__(self, s0: float, s1: float, dof: int) -> None:
        self._interval = np.array([float(s0), float(s1)])
        self._dof = int(dof)

    def __call__(self, path_positions, order: int = 0):
        raise NotImplementedError("GridPath carries no geometry (its constraints are precomputed)")

    @property
    def dof(self) -> int:
        return self._dof

    @property
    def path_interval(self) -> np.ndarray:
        return self._interval


class IntervalVelocityBounds(LinearConstraint):
    """Upper bounds on ``x = sd^2`` per gridpoint, ``xbound`` (N+1, 2) in sigma units.

    Parameters
    ----------
    xmax : (N+1,) largest admissible ``x`` at each gridpoint (>= 0)
    """

    def __init__(self, xmax: np.ndarray) -> None:
        super().__init__()
        xmax = np.asarray(xmax, dtype=np.float64)
        self._xbound = np.column_stack([np.zeros(xmax.size), xmax])
        self.dof = 0
        self.set_discretization_type(DiscretizationType.Collocation)

    def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
        if len(gridpoints) != self._xbound.shape[0]:
            raise ValueError("IntervalVelocityBounds: built for another grid")
        return None, None, None, None, None, None, self._xbound


class IntervalAccelerationRows(LinearConstraint):
    """Rows ``a_r u + b_r x + c_r <= 0`` per stage (canonical form with F = I, g = 0).

    Parameters
    ----------
    a, b, c : (N+1, m) row coefficients per stage, each row of unit norm ``hypot(a, b)``
        (or all zero with ``c = -1``: no constraint)
    """

    def __init__(self, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
        super().__init__()
        self._abc = (np.ascontiguousarray(a), np.ascontiguousarray(b), np.ascontiguousarray(c))
        m = a.shape[1]
        self.dof = m
        self.identical = True
        self._F = np.eye(m)
        self._g = np.zeros(m)
        self.set_discretization_type(DiscretizationType.Collocation)

    def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
        a, b, c = self._abc
        if len(gridpoints) != a.shape[0]:
            raise ValueError("IntervalAccelerationRows: built for another grid")
        return a, b, c, self._F, self._g, None, None


class RestToRestTOPPRA(algo.TOPPRA):
    """:class:`toppra.algorithm.TOPPRA` for rest-to-rest problems with ``x >= 0``.

    Only the two stage-wise steps are replaced, by leaner equivalents that set up the
    same LP objectives and call the same solver (the library's controllable-set and
    forward-pass loops, with their safeguards, run unchanged):

    - ``_one_step`` computes only the upper end of a controllable set: the lower end is
      0 (``u = x = 0`` is admissible at every stage and reaches the next set's lower
      end, 0, by induction from the end), which the library's second LP returns anyway;
    - ``_forward_step`` skips the library's per-call input checks (``None in K_next``
      compares a whole array) and reuses its objective vectors.

    Together they take 35 % off the library's time (2.6 s -> 1.7 s for the 386 groups
    of a 500-robot SDSS-V fold, same results).
    """

    _G_UPPER = np.array([1e-9, -1.0])      # the library's objective for the upper end

    def _one_step(self, i, K_next):
        # the caller copies the result into K[i]: one buffer serves every stage
        res = getattr(self, "_res", None)
        if res is None:
            res = self._res = np.zeros(2)
        if math.isnan(K_next[1]):
            return np.full(2, np.nan)
        res[1] = self.solver_wrapper.solve_stagewise_optim(
            i, None, self._G_UPPER, math.nan, math.nan, K_next[0], K_next[1])[1]
        return res

    def _forward_step(self, i, x, K_next):
        g = getattr(self, "_g_forward", None)
        if g is None:                      # the library's objective (-2 delta_i, -1) per stage
            g = self._g_forward = np.column_stack([-2.0 * self.solver_wrapper.get_deltas(),
                                                   -np.ones(self._N)])
        if math.isnan(x) or math.isnan(K_next[1]):
            return np.array([np.nan, np.nan])
        return self.solver_wrapper.solve_stagewise_optim(i, None, g[i], x, x, K_next[0], K_next[1])


def velocity_bounds(qd: np.ndarray, vmax: np.ndarray, sd_cap: float) -> np.ndarray:
    """The kernel's bound on ``x`` per gridpoint, (N+1,) (steps/s)^2.

    ``x_i <= v_k^2 / m_ik`` with ``m_ik`` the largest ``q'_k^2`` over gridpoints ``i - 1,
    i, i + 1`` (joints with ``|q'| <= 1e-12`` deg/step excluded), and ``x_i <= sd_cap^2``.
    ``qd`` (N+1, J) deg/step, ``vmax`` (J,) deg/s.
    """
    m = qd * qd
    m_adj = m.copy()
    m_adj[1:] = np.maximum(m_adj[1:], m[:-1])
    m_adj[:-1] = np.maximum(m_adj[:-1], m[1:])
    with np.errstate(divide="ignore"):
        bound = np.where(m_adj > 1e-24, (vmax * vmax)[None, :] / np.where(m_adj > 0, m_adj, 1.0),
                         np.inf)
    return np.minimum(bound.min(axis=1, initial=np.inf), sd_cap * sd_cap)


def _acceleration_rows(delta: np.ndarray, qd: np.ndarray, qdd: np.ndarray, amax: np.ndarray):
    """Unit-norm rows (N+1, 4J) of ``|joint acceleration| <= a`` at both interval ends."""
    N, J = qdd.shape
    A = np.zeros((N + 1, 2 * J))
    B = np.zeros((N + 1, 2 * J))
    A[:N, :J] = qd[:N]
    B[:N, :J] = qdd
    A[:N, J:] = qd[1:] + 2.0 * delta[:, None] * qdd
    B[:N, J:] = qdd
    n = np.hypot(A, B)
    zero = n == 0.0
    n[zero] = 1.0
    A /= n
    B /= n
    lim = np.tile(amax, 2)[None, :] / n
    lim[zero] = 1.0
    a = np.concatenate([A, -A], axis=1)
    b = np.concatenate([B, -B], axis=1)
    c = -np.concatenate([lim, lim], axis=1)
    return a, b, c


def solve(grid: np.ndarray, qd: np.ndarray, qdd: np.ndarray, vmax: np.ndarray,
          amax: np.ndarray, sd_cap: float) -> np.ndarray | None:
    """Time-optimal ``x = sd^2`` at the gridpoints by the toppra library, or None.

    Parameters
    ----------
    grid : (N+1,) gridpoints, plan steps (increasing)
    qd : (N+1, J) q' at the gridpoints, deg/step
    qdd : (N, J) q'' on each interval (constant), deg/step^2
    vmax, amax : (J,) limits, deg/s and deg/s^2
    sd_cap : upper bound on sd, steps/s

    Returns
    -------
    (N+1,) x in (steps/s)^2, 0 at both ends; None if the library reports no solution
    (NaN in its controllable sets or forward pass).
    """
    scale = max(1.0, float(sd_cap) / SEIDEL_SD_MAX)
    sigma = (grid - grid[0]) / scale
    qd_s = qd * scale
    qdd_s = qdd * (scale * scale)
    xmax = velocity_bounds(qd, vmax, sd_cap) / (scale * scale)
    a, b, c = _acceleration_rows(np.diff(sigma), qd_s, qdd_s, amax)
    inst = RestToRestTOPPRA([IntervalVelocityBounds(xmax), IntervalAccelerationRows(a, b, c)],
                            GridPath(sigma[0], sigma[-1], qd.shape[1]), gridpoints=sigma,
                            solver_wrapper="seidel")
    _, sd, _ = inst.compute_parameterization(0.0, 0.0)
    if sd is None or not np.all(np.isfinite(sd)):
        return None
    x = np.asarray(sd, dtype=np.float64) ** 2 * (scale * scale)
    x[0] = 0.0
    x[-1] = 0.0
    return x


def solve_law(problem: TimingProblem) -> TimeLaw | None:
    """The law computed by the library, checked (``solver == "toppra"``); None where it finds none.

    The library's forward pass lowers each ``x`` by up to 0.01 % against rounding, so
    its law can exceed the discretised constraints by a hair where the next ``x`` is
    bound by the acceleration limit; :func:`rfp_twin.planners.postprocess.timing.kernel.law_excess` measures
    that, and a law off by at most :data:`TOPPRA_TOLERANCE` is slowed down uniformly by
    the excess (a worse one counts as no solution).
    """
    grid, qd, qdd, vmax, amax = problem.grid, problem.qd, problem.qdd, problem.vmax, problem.amax
    x = solve(grid, qd, qdd, vmax, amax, problem.sd_cap)
    if x is None:
        return None
    delta = np.diff(grid)
    rv, ra = law_excess(delta, qd, qdd, vmax, amax, x, float(problem.sd_cap))
    c = max(1.0, rv, math.sqrt(ra))
    if not c <= 1.0 + TOPPRA_TOLERANCE:
        return None
    law = TimeLaw(grid, np.sqrt(x), np.diff(x) / (2.0 * delta), law_times(grid, x), "toppra")
    return law.scaled(c) if c > 1.0 else law
