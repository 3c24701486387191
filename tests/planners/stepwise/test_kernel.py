"""The stepwise kernel's Markov choice against the paper's sequential rule.

When every candidate passes the step rule the kernel draws MC's choice directly from its
closed form (``mc_pick_free`` in planners/stepwise/mc_choice.py). Here one free robot takes one step
from many seeds and the distribution of its move is compared with a plain simulation
of the sequential rule (random order, a candidate beating the best so far taken with
probability greed, a tie with probability 1/2; Sayres 2021 Sect. 4.2).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2_contingency

from rfp_twin.planners.stepwise.kernel import run_stepwise
from rfp_twin.planners.stepwise.moves import max_displacement

STEP = 0.1
LIMITS = np.array([0.0, 360.0, 0.0, 180.0])


def step_toward(cur, dest, k, lo, hi):
    nxt = min(max(cur + k * STEP, lo), hi)
    if cur > dest and nxt <= dest:
        nxt = dest
    elif cur < dest and nxt >= dest:
        nxt = dest
    return nxt


def _candidates(start, dest):
    out = []
    for ka in (-1, 0, 1):
        for kb in (-1, 0, 1):
            out.append((step_toward(start[0], dest[0], ka, LIMITS[0], LIMITS[1]),
                        step_toward(start[1], dest[1], kb, LIMITS[2], LIMITS[3])))
    return np.array(out)


def _kernel_moves(start, dest, greed, phobia, n):
    """Final (alpha, beta) of one lone robot after one kernel step, for seeds 0..n-1."""
    md = max_displacement(7.4, 15.0, 15.0, STEP)
    out = np.empty((n, 2))
    cap = 64
    for seed in range(n):
        cur = np.empty((1, 2))
        run_stepwise(np.zeros((1, 2)), np.array([start]), np.array([dest]), np.ones(1, bool),
                     np.zeros(2, np.int64), np.zeros(0, np.int64), np.zeros(0),
                     np.zeros(2, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)), 1.5,
                     7.4, 0.0, np.array([15.0]), np.array([2.0]), LIMITS, STEP, 1, md,
                     np.array([greed]), phobia, seed, np.empty(cap, np.int64),
                     np.empty(cap, np.int64), np.empty((cap, 2)), cur)
        out[seed] = cur[0]
    return out


def _sequential_rule(scores, greed, n, rng):
    """Index of the chosen candidate (-1: none) for n independent visits, vectorised."""
    order = rng.permuted(np.tile(np.arange(9), (n, 1)), axis=1)
    best = np.full(n, -1)
    best_score = np.full(n, np.inf)
    for p in range(9):
        q = order[:, p]
        sc = scores[q]
        u = rng.random(n)
        take = ((sc < best_score) & (u < greed)) | ((sc == best_score) & (u < 0.5))
        best = np.where(take, q, best)
        best_score = np.where(take, sc, best_score)
    return best


def _outcome_labels(moves, start):
    """Label each final configuration by its move (dalpha, dbeta) rounded to 1e-6 deg."""
    d = np.round(moves - np.asarray(start), 6)
    return [tuple(r) for r in d]


@pytest.mark.parametrize("start, dest, greed, phobia", [
    ((40.0, 90.0), (10.0, 170.0), 0.9, 0.0),    # no ties: the paper's greed
    ((10.0, 100.0), (10.0, 170.0), 0.6, 0.0),   # alpha at its destination: +-d tie
    ((50.0, 180.0), (10.0, 170.0), 0.6, 0.0),   # beta at its limit: duplicate candidates
    ((40.0, 90.0), (10.0, 170.0), 0.7, 1.0),    # energy with no neighbour: all nine tie
])
def test_free_choice_matches_sequential_rule(start, dest, greed, phobia):
    n = 12000
    kernel = _outcome_labels(_kernel_moves(start, dest, greed, phobia, n), start)
    cands = _candidates(start, dest)
    if phobia > 0.0:
        scores = np.zeros(9)       # E = 0 for every candidate when no neighbour is near
    else:
        scores = ((cands - np.asarray(dest)) ** 2).sum(axis=1)
    pick = _sequential_rule(scores, greed, n, np.random.default_rng(7))
    ref_moves = np.where(pick[:, None] >= 0, cands[np.maximum(pick, 0)], np.asarray(start))
    reference = _outcome_labels(ref_moves, start)
    labels = sorted(set(kernel) | set(reference))
    counts = np.array([[kernel.count(lab) for lab in labels],
                       [reference.count(lab) for lab in labels]])
    # moves seen fewer than 20 times in all are pooled (chi-square needs filled cells)
    common = counts.sum(axis=0) >= 20
    table = counts[:, common]
    if (~common).any():
        table = np.column_stack([table, counts[:, ~common].sum(axis=1)])
    assert common.sum() >= 3
    assert chi2_contingency(table).pvalue > 1e-3, (labels, counts)
    if phobia == 0.0 and greed == 0.9:
        # the best move (one step toward the destination on both axes) dominates
        assert max(set(kernel), key=kernel.count) == (-STEP, STEP)
