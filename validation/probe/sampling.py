"""What the probe checks sample: a plan's breakpoints on a regular time grid, in chunks.

Both :func:`~rfp_twin.validation.probe.check.check_probe_plan` (2D) and
:func:`~rfp_twin.validation.probe.check3d.check_probe_plan_3d` (FCL) read a plan the same way:
every arm once, samples ``0, dt_s, 2 dt_s, ...`` up to the last breakpoint of any arm, taken in
chunks to bound memory; their reports share the record of what was sampled. Units: mm, s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfp_twin.models.errors import TrajectoryError


@dataclass(kw_only=True)
class ProbeSampling:
    """What a probe check looked at: ``buffer_mm`` each arm's safety buffer, mm; ``dt_s`` the
    sample spacing, s; ``n_samples`` samples per arm; ``duration_s`` the plan's end, s."""

    buffer_mm: float = 0.0
    dt_s: float = 0.0
    n_samples: int = 0
    duration_s: float = 0.0


def plan_arrays(breakpoints: dict, n_arms: int) -> dict:
    """{arm: (times (k,) s, configs (k, 2) deg)} as float arrays; raises TrajectoryError
    unless every arm ``0..n_arms - 1`` is there once."""
    if sorted(breakpoints) != list(range(n_arms)):
        raise TrajectoryError(f"probe plan arms {sorted(breakpoints)}; allowed: every arm "
                              f"0..{n_arms - 1} once")
    return {i: (np.asarray(t, float), np.asarray(q, float)) for i, (t, q) in breakpoints.items()}


def sample_count(plan: dict, dt_s: float) -> tuple[float, int]:
    """(end time s, number of samples) of the grid ``0, dt_s, ...`` covering ``plan``."""
    t_end = max(float(t[-1]) for t, _ in plan.values())
    return t_end, int(math.ceil(t_end / dt_s - 1e-9)) + 1


def time_chunks(n_samples: int, dt_s: float, chunk: int):
    """The sample times ``dt_s * k``, k < ``n_samples``, as arrays of at most ``chunk``."""
    for lo in range(0, n_samples, chunk):
        yield dt_s * np.arange(lo, min(n_samples, lo + chunk))
