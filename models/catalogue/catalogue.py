"""Catalogue: the targets of one pointing as flat arrays, in the planning frame.

A target has an integer id, a position ``(x_mm, y_mm)`` in the layout's planning frame
(the frame robot bases are given in; a calibrated SDSS-V instrument's planning frame is
its wok frame turned by +90 deg, :func:`rfp_twin.models.instrument.wok_to_plane`), a
priority (a weight >= 0: an assigner maximises the sum of the priorities of the targets
it observes, so a larger priority is more valuable), a kind (``science``, ``sky``,
``standard``) and the fiber it needs (``boss``, ``apogee``, ``any``), and how many
exposures it needs to be complete (1 unless the catalogue says more: faint targets
observed in several passes). Kinds and fibers are stored as small integer codes (indices
into :data:`KINDS` and :data:`FIBERS`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfp_twin.models.errors import CatalogueError

#: Target kinds, in code order (``Catalogue.kind`` holds indices into this tuple).
KINDS = ("science", "sky", "standard")
SCIENCE, SKY, STANDARD = 0, 1, 2
#: Most exposures one target may ask for.
MAX_EXPOSURES = 1000
#: Fibers a target may ask for, in code order (``Catalogue.fiber``).
TARGET_FIBERS = ("boss", "apogee", "any")
BOSS, APOGEE, ANY = 0, 1, 2


@dataclass(frozen=True)
class Catalogue:
    """Targets of one pointing (t targets).

    Attributes
    ----------
    ids : (t,) int64, unique
    xy : (t, 2) float64 positions in the planning frame, mm (finite)
    priority : (t,) float64 weights >= 0 (larger: more valuable)
    kind : (t,) int8 codes into :data:`KINDS`
    fiber : (t,) int8 codes into :data:`TARGET_FIBERS`
    source : where the catalogue came from (a file, ``mock:...``), for messages
    exposures : (t,) int64 in [1, MAX_EXPOSURES], exposures each target needs to be
        complete [default: 1 each]
    """

    ids: np.ndarray
    xy: np.ndarray
    priority: np.ndarray
    kind: np.ndarray
    fiber: np.ndarray
    source: str = "<memory>"
    exposures: np.ndarray | None = None

    def __post_init__(self) -> None:
        ids = np.asarray(self.ids, dtype=np.int64).reshape(-1)
        t = ids.size
        xy = np.asarray(self.xy, dtype=np.float64).reshape(t, 2)
        pr = np.asarray(self.priority, dtype=np.float64).reshape(t)
        kind = np.asarray(self.kind, dtype=np.int8).reshape(t)
        fiber = np.asarray(self.fiber, dtype=np.int8).reshape(t)
        exp = (np.ones(t, dtype=np.int64) if self.exposures is None
               else np.asarray(self.exposures).reshape(t))
        bad = bad_exposures(exp)
        if bad.size:
            r = int(bad[0])
            raise CatalogueError(f"{self.source}: row {r}: target {int(ids[r])}: field "
                                 f"'exposures' = {exp[r]!r}; allowed: an integer in "
                                 f"[1, {MAX_EXPOSURES}]")
        exp = exp.astype(np.int64)
        for name, arr in (("ids", ids), ("xy", xy), ("priority", pr), ("kind", kind),
                          ("fiber", fiber), ("exposures", exp)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        self.check()

    def check(self) -> None:
        """CatalogueError for the first bad row: NaN position, repeated id, negative or
        NaN priority, unknown kind or fiber code (row numbers from 0)."""
        where = f"{self.source}: row"
        bad = np.flatnonzero(~np.isfinite(self.xy).all(axis=1))
        if bad.size:
            r = int(bad[0])
            raise CatalogueError(f"{where} {r}: target {int(self.ids[r])}: position "
                                 f"{self.xy[r].tolist()}; allowed: finite x, y in mm")
        bad = np.flatnonzero(~(np.isfinite(self.priority) & (self.priority >= 0.0)))
        if bad.size:
            r = int(bad[0])
            raise CatalogueError(f"{where} {r}: target {int(self.ids[r])}: field 'priority' = "
                                 f"{float(self.priority[r])!r}; allowed: a finite number >= 0")
        for name, codes, names in (("kind", self.kind, KINDS), ("fiber", self.fiber,
                                                                TARGET_FIBERS)):
            bad = np.flatnonzero((codes < 0) | (codes >= len(names)))
            if bad.size:
                r = int(bad[0])
                raise CatalogueError(f"{where} {r}: field {name!r} = {int(codes[r])}; allowed: "
                                     f"{', '.join(names)}")
        order = np.argsort(self.ids, kind="stable")
        rep = np.flatnonzero(np.diff(self.ids[order]) == 0)
        if rep.size:
            r = int(order[rep[0] + 1])
            raise CatalogueError(f"{where} {r}: field 'id' = {int(self.ids[r])} repeats row "
                                 f"{int(order[rep[0]])}; allowed: unique ids")

    # -- queries -------------------------------------------------------------
    @property
    def n_targets(self) -> int:
        return int(self.ids.size)

    def __len__(self) -> int:
        return self.n_targets

    def counts(self) -> dict[str, int]:
        """Number of targets of each kind, {kind name: count}."""
        return {name: int(np.count_nonzero(self.kind == k)) for k, name in enumerate(KINDS)}

    # -- building ------------------------------------------------------------
    def subset(self, mask: np.ndarray) -> "Catalogue":
        """The targets where ``mask`` (t,) bool (or an index array) selects them."""
        return Catalogue(self.ids[mask], self.xy[mask], self.priority[mask], self.kind[mask],
                         self.fiber[mask], self.source, self.exposures[mask])

    @classmethod
    def concat(cls, parts: list["Catalogue"], source: str | None = None) -> "Catalogue":
        """One catalogue of several (ids must stay unique)."""
        return cls(np.concatenate([p.ids for p in parts]),
                   np.concatenate([p.xy for p in parts]).reshape(-1, 2),
                   np.concatenate([p.priority for p in parts]),
                   np.concatenate([p.kind for p in parts]),
                   np.concatenate([p.fiber for p in parts]),
                   source or " + ".join(p.source for p in parts),
                   np.concatenate([p.exposures for p in parts]))


def bad_exposures(values) -> np.ndarray:
    """Indices of the entries of ``values`` (array-like of numbers) that are not an integer
    in [1, :data:`MAX_EXPOSURES`] (NaN included)."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    return np.flatnonzero(~((v >= 1) & (v <= MAX_EXPOSURES) & (v == np.round(v))))


def code_of(value: str, names: tuple[str, ...]) -> int:
    """Index of ``value`` (case and blanks ignored) in ``names``; -1 when not there."""
    v = str(value).strip().lower()
    return names.index(v) if v in names else -1
