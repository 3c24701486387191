"""The MIRADAS bench as a :class:`~rfp_twin.models.layout.Layout` (``--layout miradas-N``).

N probe arms of the ``miradas-probe`` preset on its circular bench: ids 0..N-1
counter-clockwise (Sabater 2018 Fig. 11), J1 of each arm in mm (field centre at the
origin), ``extra["heading_deg"]`` the direction of each arm frame's x axis.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.kinds.probe_spec import load_probe_spec

#: The probe-arm preset that ``miradas-N`` layouts take their bench from.
MIRADAS_PRESET = "miradas-probe"


def probe_bench_layout(name: str = "miradas-12", preset: str | Path = MIRADAS_PRESET):
    """``miradas-N``: N probe arms of ``preset`` on its bench, as a Layout."""
    from rfp_twin.models.layout.core import Layout

    try:
        n = int(name.split("-", 1)[1])
    except (IndexError, ValueError):
        raise LayoutError(f"layout {name!r}: 'miradas-N' needs an integer N") from None
    if not 1 <= n <= 64:
        raise LayoutError(f"layout {name!r}: N = {n}; allowed: [1, 64] arms")
    spec = load_probe_spec(preset).with_overrides(n_arms=n)
    return Layout(np.arange(n), spec.bases(), ["robot"] * n, name=name,
                  extra={"heading_deg": np.degrees(spec.headings_rad())})
