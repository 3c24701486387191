"""Timing backends: solvers of one group's discretised TOPP-RA problem, chosen by name.

Every backend is a module of this package with one function, ``solve_law(problem) ->
TimeLaw | None``, that solves a :class:`TimingProblem` (the constraints of
:mod:`rfp_twin.planners.postprocess.timing.kernel` on the group's grid) and returns the time law, or None
where it finds no solution. All solve the same discretised problem on the same
gridpoints:

- ``"toppra"`` (:mod:`.toppra_library`): the ``toppra`` 0.6 library, its
  ``TOPPRA`` algorithm and seidel LP solver, given the constraints as precomputed unit
  rows; it gives the kernel's laws (tests/planners/postprocess/timing/test_backends.py
  compares them group by group on real plans) and stays as the independent cross-check
  (``rfp-twin plan --timing-backend toppra``);
- ``"numba"`` (default, :mod:`.numba_kernel`): the kernel
  :func:`rfp_twin.planners.postprocess.timing.kernel.topp_kernel`, without the library's
  Python loops (its backward and forward passes run per gridpoint in Python) and without
  importing the library and matplotlib in a fresh process; it always finds a law, and
  :func:`rfp_twin.planners.postprocess.timing.time_group` also uses it for groups the
  library finds no solution for (``TimeLaw.solver == "fallback"``) and for groups too
  large for the library (``"numba-large"``).

A backend module is imported on first use (:func:`get_backend`): the ``toppra`` library
and the matplotlib it imports take ~0.3 s.

Units: plan steps, degrees, seconds.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.planners.postprocess.timing.law import TimeLaw

__all__ = ["BACKENDS", "DEFAULT_BACKEND", "TimingProblem", "get_backend"]

#: Backend name -> module of this package.
_MODULES = {"toppra": "toppra_library", "numba": "numba_kernel"}
#: Names of the backends.
BACKENDS = tuple(_MODULES)
#: Backend of :func:`rfp_twin.planners.postprocess.timing.time_group` (and of the post-processing pipeline).
DEFAULT_BACKEND = "numba"


@dataclass(frozen=True)
class TimingProblem:
    """One group's discretised time-optimal problem, from rest to rest.

    Attributes
    ----------
    grid : (N+1,) gridpoints, plan steps (increasing, N >= 1)
    qd : (N+1, J) q' at the gridpoints, deg/step (J = 2 joints per robot)
    qdd : (N, J) q'' on each interval (constant), deg/step^2
    vmax, amax : (J,) joint limits, deg/s and deg/s^2
    sd_cap : upper bound on ds/dt where no joint moves, steps/s
    """

    grid: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    vmax: np.ndarray
    amax: np.ndarray
    sd_cap: float


def get_backend(name: str) -> Callable[[TimingProblem], Optional[TimeLaw]]:
    """The ``solve_law`` function of backend ``name`` (one of :data:`BACKENDS`)."""
    if name not in _MODULES:
        raise field_error(SpecError, "backend", name, ", ".join(BACKENDS), "time_group")
    return importlib.import_module(f"{__name__}.{_MODULES[name]}").solve_law
