"""Completeness: the share of a catalogue's science targets observed, overall and by priority.

A survey reports completeness as observed / available science targets (calibration
targets, sky and standards, are re-used every exposure and never "complete"). Targets
of different priorities fare differently (the assigner takes the valuable ones first),
so the figure is also given per priority value.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.catalogue import SCIENCE, Catalogue


def completeness(catalogue: Catalogue, observed: np.ndarray,
                 reachable: np.ndarray | None = None) -> dict:
    """Completeness of ``catalogue``'s science targets given ``observed`` ((t,) bool, one per
    catalogue row); ``reachable`` ((t,) bool, optional): the targets some robot reaches.

    Returns ``{"science": observed / science targets (None without science targets),
    "n_science": int, "n_observed": int, "by_priority": {priority (str, as "%g"):
    {"n": targets, "observed": observed, "completeness": share}}}``, priorities in
    decreasing order; with ``reachable`` also ``"n_within_reach"`` and
    ``"within_reach"``: observed / science targets within reach (None without any)."""
    observed = np.asarray(observed, dtype=bool).reshape(catalogue.n_targets)
    science = catalogue.kind == SCIENCE
    n_sci = int(science.sum())
    seen = observed & science
    by = {}
    for p in np.unique(catalogue.priority[science])[::-1]:
        at = science & (catalogue.priority == p)
        n, k = int(at.sum()), int((seen & at).sum())
        by[f"{float(p):g}"] = {"n": n, "observed": k, "completeness": k / n}
    out = {"science": (int(seen.sum()) / n_sci) if n_sci else None, "n_science": n_sci,
           "n_observed": int(seen.sum()), "by_priority": by}
    if reachable is not None:
        near = science & np.asarray(reachable, dtype=bool).reshape(catalogue.n_targets)
        out["n_within_reach"] = int(near.sum())
        out["within_reach"] = int((seen & near).sum()) / int(near.sum()) if near.any() else None
    return out


def reachable_rows(catalogue: Catalogue, cands) -> np.ndarray:
    """(t,) bool: the catalogue rows that some candidate pose of ``cands``
    (:class:`rfp_twin.planners.assignment.Candidates` built on ``catalogue``) reaches."""
    out = np.zeros(catalogue.n_targets, dtype=bool)
    out[cands.target[cands.target >= 0]] = True
    return out


def observed_rows(catalogue: Catalogue, target_ids: np.ndarray) -> np.ndarray:
    """(t,) bool: the catalogue rows whose id is among ``target_ids`` (ids < 0 ignored)."""
    ids = np.asarray(target_ids, dtype=np.int64).reshape(-1)
    return np.isin(catalogue.ids, ids[ids >= 0])
