"""Part (c) of the calibration: the buffer that angular errors call for (Monte Carlo).

A commanded configuration ``c`` is reached as ``c + e``, ``e`` uniform in ``[-ea, ea] x
[-eb, eb]`` per robot (default the paper's worst-case 1.50 / 1.48 deg, Sayres et al.
2021, Sect. 6). For one draw ``e``, every 2D-safe ``c`` stays 3D-safe iff ``b >= B(e) =
max required(c' - e)`` over the 3D-colliding actual configurations ``c'``. ``B(e)`` is
estimated from candidate configurations (3D-colliding, near the largest ``required``)
and a local search from the best few (:func:`rfp_twin.validation.buffer.sampling.climb`).

With an instrument's metrology spread (:mod:`rfp_twin.validation.buffer.metrology`), a
draw is ``(e, m)``: angular errors and the deviations ``m`` of two real robots. The
perturbed robots collide at ``c`` iff the nominal ones collide at the configuration ``c~``
that puts the beta arms in the same place, so ``B(e, m) = max required(c(c~; m) - e)``
over the nominal 3D-colliding ``c~``: the same candidates and search, with the
objective taken at the mapped configuration (``actual``; :func:`spread_buffers`).
Units: mm, deg.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from rfp_twin.validation.buffer.sampling import climb, distinct_top


class ErrorBuffer:
    """``B(e)`` for draws ``e`` of the angular errors, from fixed candidates.

    Parameters
    ----------
    required : callable(angles (n, 4) deg, direction index (n,)) -> (n,) mm
        The smallest buffer whose 2D model forbids each configuration.
    classify : callable(angles, direction index) -> (n,) bool
        Exact 3D collision of each configuration.
    cand_ang : (k, 4) deg; cand_dir : (k,) int
        Candidate actual configurations ``c'`` (3D-colliding) and their directions.
    rng : numpy Generator
        Drives the local search.
    actual : callable(angles (n, 4) deg, direction index (n,), deviations (2, 4)) ->
        (angles (n, 4) deg, ok (n,) bool), optional
        With a draw's deviations ``m``: the configuration of the perturbed robots whose
        beta arms stand as the nominal ones at each candidate (ok False: none).
    """

    def __init__(self, required: Callable, classify: Callable, cand_ang: np.ndarray,
                 cand_dir: np.ndarray, rng, actual: Callable | None = None):
        self.required = required
        self.classify = classify
        self.ang = cand_ang
        self.dir = cand_dir
        self.rng = rng
        self.actual = actual

    def _objective(self, err: np.ndarray, dev) -> Callable:
        """required(c - e), at the perturbed robots' configuration c(c~; m) when a draw
        has deviations (-inf where there is none)."""
        if dev is None:
            return lambda a, d: self.required(a - err, d)

        def obj(a, d):
            act, ok = self.actual(a, d, dev)
            out = np.full(len(a), -np.inf)
            if ok.any():
                out[ok] = self.required(act[ok] - err, d[ok])
            return out
        return obj

    def __call__(self, err: np.ndarray, starts: int, rounds: int, dev=None):
        """B(e) (or B(e, m) with deviations ``dev`` (2, 4) mm): the best of the
        candidates, then a local search in the actual configuration c' (kept in 3D
        collision) raising required(c' - e). Returns (B, c', direction index); with
        ``dev``, c' is the nominal robots' configuration (:meth:`_objective`)."""
        if not len(self.ang):
            return 0.0, None, -1
        objective = self._objective(err, dev)
        vals = objective(self.ang, self.dir)
        i = int(np.argmax(vals))
        if not np.isfinite(vals[i]):
            return 0.0, None, -1
        best = (float(vals[i]), self.ang[i], int(self.dir[i]))
        if rounds == 0:
            return best
        top = distinct_top(vals, self.ang, self.dir, starts)
        ang_b, val_b, _, _, _ = climb(objective, self.classify,
                                      self.ang[top], self.dir[top], self.rng,
                                      rounds=rounds, batch=16, step_deg=0.5)
        j = int(np.argmax(val_b))
        if val_b[j] > best[0]:
            best = (float(val_b[j]), ang_b[j], int(self.dir[top][j]))
        return best


def corner_errors(ea: float, eb: float) -> np.ndarray:
    """The 16 errors with every component at its bound, (16, 4) deg."""
    return np.array([[sa * ea, sb * eb, sc * ea, sd * eb] for sa in (-1, 1) for sb in (-1, 1)
                     for sc in (-1, 1) for sd in (-1, 1)], dtype=float)


def error_buffers(b_of: ErrorBuffer, draws: np.ndarray, corners: np.ndarray, starts: int,
                  rounds: int, report: Callable[[str, float], None]):
    """``B`` without errors (longer search), ``B(e)`` per draw, and the worst corner.

    Returns ``((B0, c', direction index), samples (n_draws,) mm, corner mm)``; the
    error-free and corner searches use 4x the starts and at least 4x10 rounds.
    """
    long = (4 * starts, 4 * max(rounds, 10))
    free = b_of(np.zeros(4), *long)
    samples = np.empty(len(draws))
    for k in range(len(draws)):
        samples[k] = b_of(draws[k], starts, rounds)[0]
        if k % 50 == 0:
            report("monte carlo", k / len(draws))
    corner = max(b_of(c, *long)[0] for c in corners)
    return free, samples, corner


def spread_buffers(b_of: ErrorBuffer, draws: np.ndarray, devs: np.ndarray, starts: int,
                   rounds: int, report: Callable[[str, float], None]) -> np.ndarray:
    """``B(e, m)`` per draw: angular errors ``draws`` (n, 4) deg and the two robots'
    deviations ``devs`` (n, 2, 4) mm. Returns (n,) mm."""
    samples = np.empty(len(draws))
    for k in range(len(draws)):
        samples[k] = b_of(draws[k], starts, rounds, devs[k])[0]
        if k % 50 == 0:
            report("metrology spread", k / len(draws))
    return samples
