"""The passes option of ``rfp-twin plan --catalogue``, declared once (:mod:`rfp_twin.models.options`).

Kept apart from :mod:`rfp_twin.twin.passes` so that the CLI builds its options without
loading the planners.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfp_twin.models.errors import RfpError
from rfp_twin.models.options import option

#: Most passes of one field.
MAX_PASSES = 100


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
                         "assigns the science targets not yet observed and its motion starts "
                         "at the last pass's poses (a run folder per pass, passes.csv, "
                         "observed.csv)", lo=1, hi=MAX_PASSES)

    def __post_init__(self) -> None:
        check_passes(self.passes)
