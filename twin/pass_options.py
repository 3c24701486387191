"""The passes option of ``rfp-twin plan --catalogue``, declared once (:mod:`rfp_twin.models.options`).

Kept apart from :mod:`rfp_twin.twin.passes` so that the CLI builds its options without
loading the planners.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfp_twin.models.errors import RfpError
from rfp_twin.models.options import option, option_info

#: Most passes of one field.
MAX_PASSES = 100
#: Default share of the robots a direct motion's first run may leave stuck for the whole
#: pipeline (deadlock search) to be tried on it. On a DESI-like array (hex:547, 5 targets
#: per robot) passes 3-5 leave 2-6 % stuck: at 0.02 they move via the fold (4.8-5.0 s),
#: at 0.1 the search keeps every target on the direct motion (2.5-4.4 s) for ~10 s more
#: computing per field.
DIRECT_STUCK_SHARE = 0.1


def check_passes(passes) -> int:
    """``passes`` as an int in [1, :data:`MAX_PASSES`]; RfpError (one line) otherwise."""
    if isinstance(passes, bool) or not isinstance(passes, (int, np.integer)) \
            or not 1 <= passes <= MAX_PASSES:
        raise RfpError(f"--passes {passes!r}; allowed: an integer in [1, {MAX_PASSES}]")
    return int(passes)


@dataclass(frozen=True)
class PassOptions:
    """How many times the field is observed (``plan --catalogue``)."""

    passes: int = option(1, "--catalogue: observe the field this many times; each pass "
                         "assigns the science targets that still need an exposure (catalogue "
                         "column exposures, default 1) and its motion starts "
                         "at the last pass's poses (a run folder per pass, passes.csv, "
                         "observed.csv)", lo=1, hi=MAX_PASSES)
    direct_stuck: float = option(DIRECT_STUCK_SHARE, "--passes: the direct motion from the "
                                 "last poses is searched (deadlock resolution) when its first "
                                 "run leaves at most this share of the robots stuck (at least "
                                 "2); otherwise, or if it loses a target, the robots go via "
                                 "the fold", lo=0.0, hi=1.0)

    def __post_init__(self) -> None:
        check_passes(self.passes)
        v = self.direct_stuck
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v <= 1.0:
            raise RfpError(f"--direct-stuck {v!r}; allowed: "
                           f"{option_info(self, 'direct_stuck').allowed()}")
