"""The CPU cores this process may use (its affinity mask where the OS has one), shared by
the default study cluster's worker count, the CLI's help text and the tiled simulation's
threads. No heavy imports: the CLI reads it before anything else is loaded."""
from __future__ import annotations

import os

__all__ = ["usable_cores"]


def usable_cores() -> int:
    """Cores this process may run on (at least one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover (not Linux)
        return max(1, os.cpu_count() or 1)
