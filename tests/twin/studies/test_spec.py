"""Grid points, trials, seeds and keys (twin/studies/spec.py)."""
from __future__ import annotations

from tests.twin.studies.builders import TINY, study_file
from rfp_twin.twin.studies import parse_study
from rfp_twin.twin.studies.spec import point_layout


def test_trial_seeds_and_keys_are_stable_and_distinct(tmp_path):
    a = study_file(TINY, tmp_path).trial_list()
    b = parse_study(TINY).trial_list()
    assert [(t.key, t.seed) for t in a] == [(t.key, t.seed) for t in b]
    assert len({t.key for t in a}) == len(a) == 8 and len({t.seed for t in a}) == 8
    assert all(0 <= t.seed < 2**63 for t in a)
    # the base seed changes every trial; greed does not matter for greedy points
    other = parse_study(TINY.replace("seed = 11", "seed = 12")).trial_list()
    assert not {t.key for t in a} & {t.key for t in other}
    g = parse_study(TINY.replace('algorithm = ["GC", "MC"]', 'algorithm = "GC"\ngreed = [0.5, 0.9]'))
    assert len(g.points) == 2  # two buffers; greed collapses for GC


def test_trials_cover_the_grid_evenly_and_keys_do_not_depend_on_the_count():
    study = parse_study(TINY)
    trials = study.trial_list(3)
    n = len(study.points)
    assert [t.index for t in trials] == [i for i in range(3) for _ in range(n)]
    assert [t.point for t in trials[:n]] == list(study.points)
    # more trials per point later extend the same study: the first ones keep their keys
    assert [t.key for t in trials[:2 * n]] == [t.key for t in study.trial_list()]
    p = study.points[0]
    assert p.trial_key(study.seed, 0) != p.trial_key(study.seed + 1, 0)
    assert len(p.point_id) == 12 and p.point_id != study.points[1].point_id


def test_point_layouts():
    assert point_layout("sdss-v-fps", 0, 0.0).n_robots == 500
    hexes = point_layout("hex", 37, 20.0)
    assert hexes.n_robots == 37 and hexes.n_fiducials == 0
    assert point_layout("hex", 37, 20.0) is hexes      # cached: one per process
