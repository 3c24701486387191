"""The coverage map: multiplicity per grid cell as a PNG (matplotlib, Agg, loaded lazily).

Colours: 0 (no fiber) white, 1, 2, 3 and 4+ fibers from light yellow to dark brown,
with a colour bar; the focal-plane outline (:data:`rfp_twin.models.coverage.FOCAL_PLANE`)
dashed blue; robot bases as dots when there are few enough to see. Axes in mm. The
file is written atomically (:func:`rfp_twin.models.files.atomic_write_bytes`).
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from rfp_twin.models.files import atomic_write_bytes

#: Colour of multiplicity 0, 1, 2, 3, 4+.
COLOURS = ("#ffffff", "#fee391", "#fe9929", "#cc4c02", "#662506")
LABELS = ("0", "1", "2", "3", "4+")
#: Robot bases are drawn up to this many robots.
MAX_DRAWN_BASES = 1000


def _summary(cov) -> str:
    """Second title line: the >= k fractions (or areas without a focal plane)."""
    if cov.fraction is None:
        return "reached by >= 1 / 2 / 3 fibers: " + " / ".join(
            f"{cov.area_mm2[k]:.4g}" for k in ("1", "2", "3")) + " mm$^2$"
    return "focal plane reached by >= 1 / 2 / 3 fibers: " + " / ".join(
        f"{100 * cov.fraction[k]:.2f}%" for k in ("1", "2", "3"))


def coverage_png(cov, title: str | None = None, dpi: int = 150) -> bytes:
    """PNG bytes of the multiplicity map of a :class:`rfp_twin.models.coverage.Coverage`."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.figure import Figure
    from mpl_toolkits.axes_grid1 import make_axes_locatable

    m = cov.map
    fig = Figure(figsize=(8.0, 7.2), dpi=dpi)
    FigureCanvasAgg(fig)                              # Agg, whatever pyplot's backend is
    ax = fig.add_subplot(1, 1, 1)
    cmap = ListedColormap(COLOURS)
    norm = BoundaryNorm(np.arange(-0.5, len(COLOURS)), cmap.N)
    shown = np.minimum(m.image, len(COLOURS) - 1)
    im = ax.imshow(shown, origin="lower", extent=m.extent, cmap=cmap, norm=norm,
                   interpolation="nearest")
    if len(m.hull):
        ring = np.vstack([m.hull, m.hull[:1]])
        ax.plot(ring[:, 0], ring[:, 1], "--", color="#1f5fbf", lw=1.2, label="focal plane")
        ax.legend(loc="upper right", fontsize=8, framealpha=0.9)
    if len(m.bases) <= MAX_DRAWN_BASES:
        ax.plot(m.bases[:, 0], m.bases[:, 1], ".", color="black", ms=2)
    ax.set_aspect("equal")
    cax = make_axes_locatable(ax).append_axes("right", size="4%", pad=0.15)
    bar = fig.colorbar(im, cax=cax, ticks=np.arange(len(COLOURS)))
    bar.ax.set_yticklabels(LABELS)
    bar.set_label("fibers reaching the point")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    head = title or f"{cov.layout} ({cov.n_robots} robots), {cov.spec}"
    ax.set_title(f"{head}\n{_summary(cov)}", fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def write_coverage_png(cov, path: str | Path, title: str | None = None) -> Path:
    """Write the multiplicity map of ``cov`` to ``path`` atomically; returns the path."""
    path = Path(path)
    atomic_write_bytes(path, coverage_png(cov, title))
    return path
