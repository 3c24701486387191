"""Random tip-model configurations (Makarem 2014 Sect. 6): planners/fields/tips.py."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError, TargetError
from rfp_twin.planners.fields import random_tip_configs
from tests.planners.fields.cases import DESI, custom_geom, desi_geom, tips


def min_tip_distance(geom, angles) -> float:
    t = tips(geom, angles)
    d = np.hypot(*(t[:, None, :] - t[None, :, :]).transpose(2, 0, 1))
    return float(d[np.triu_indices(len(t), 1)].min())


def test_tips_are_apart_right_armed_and_seeded():
    geom = desi_geom(37)
    a = random_tip_configs(geom, np.random.default_rng(5), 3.0)
    b = random_tip_configs(geom, np.random.default_rng(5), 3.0)
    np.testing.assert_array_equal(a, b)
    assert a.shape == (37, 2) and min_tip_distance(geom, a) > 3.0
    assert np.all((a[:, 1] >= 0.0) & (a[:, 1] <= 180.0))          # right-armed


def test_fixed_rows_are_kept_and_avoided():
    geom = desi_geom(19)
    init = random_tip_configs(geom, np.random.default_rng(1), 3.0)
    fixed = np.zeros(19, dtype=bool)
    fixed[[0, 7]] = True
    out = random_tip_configs(geom, np.random.default_rng(2), 3.0, fixed=fixed, initial=init)
    np.testing.assert_array_equal(out[fixed], init[fixed])
    assert not np.allclose(out[~fixed], init[~fixed])
    assert min_tip_distance(geom, out) > 3.0


def test_fiducial_disks_are_avoided():
    geom = custom_geom(DESI, [[0.0, 0.0], [4.0, 0.0]], ["robot", "fiducial"])
    out = random_tip_configs(geom, np.random.default_rng(0), 2.0)
    assert np.hypot(*(tips(geom, out)[0] - [4.0, 0.0])) > 1.0 + DESI.fiducial_buffer_mm


def test_impossible_separation_and_bad_input_are_errors():
    geom = desi_geom(7)
    with pytest.raises(TargetError, match="no random tip position > 20.0 mm"):
        random_tip_configs(geom, np.random.default_rng(0), 20.0, pool=8, attempts=2)
    with pytest.raises(SpecError, match="field 'min_sep_mm'"):
        random_tip_configs(geom, np.random.default_rng(0), 0.0)
