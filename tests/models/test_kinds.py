"""Robot kinds: the alpha/beta view of a RobotSpec, kind selection by preset, refusals."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import KindError
from rfp_twin.models.kinds import (ALPHA_BETA, MIRADAS_PROBE, AlphaBetaKind, ProbeArmKind,
                                   load_kind, require_kind)
from rfp_twin.models.kinematics import forward, inverse
from rfp_twin.models.robot import list_presets, load_spec, preset_kind


def test_presets_state_their_kind():
    assert "miradas-probe" not in list_presets()            # the alpha/beta presets
    assert "miradas-probe" in list_presets(None)
    assert list_presets(MIRADAS_PROBE) == ["miradas-probe"]
    assert all(preset_kind(n) == ALPHA_BETA for n in list_presets())
    assert isinstance(load_kind("sdss-v"), AlphaBetaKind)
    assert isinstance(load_kind("miradas-probe"), ProbeArmKind)


def test_alpha_beta_loader_refuses_a_probe_preset_in_one_line():
    with pytest.raises(KindError) as exc:
        load_spec("miradas-probe")
    msg = str(exc.value)
    assert "\n" not in msg and "'miradas-probe'" in msg and "alpha-beta" in msg


def test_alpha_beta_kind_is_the_spec_kinematics():
    spec = load_spec("sdss-v")
    kind = AlphaBetaKind(spec)
    rng = np.random.default_rng(3)
    q = np.column_stack([rng.uniform(0, 360, 50), rng.uniform(5, 175, 50)])
    fiber, elbow = forward(np.zeros((50, 2)), q, spec.alpha_length_mm, spec.beta_length_mm)
    np.testing.assert_allclose(kind.forward(q), fiber)
    np.testing.assert_allclose(kind.inverse(fiber),
                               inverse(np.zeros((50, 2)), fiber, spec.alpha_length_mm,
                                       spec.beta_length_mm), atol=1e-9)
    caps = kind.bodies(q)
    assert caps.shape == (50, 1, 5)
    np.testing.assert_allclose(caps[:, 0, :2], elbow, atol=1e-9)      # segment starts at 0
    np.testing.assert_allclose(np.hypot(*(caps[:, 0, 2:4] - elbow).T), spec.segment_end())
    assert np.all(caps[:, 0, 4] == spec.buffer_mm)
    assert kind.forbidden(np.array([[10.0, 170.0], [-1.0, 10.0], [10.0, 361.0]])).tolist() == \
        [False, True, True]
    assert np.isnan(kind.inverse(np.array([[40.0, 0.0]]))).all()     # beyond reach


def test_require_kind_names_the_component_and_the_kind():
    require_kind(ALPHA_BETA, (ALPHA_BETA,), "planner 'greedy'")
    with pytest.raises(KindError, match=r"^planner 'greedy' does not support robot kind "
                                        r"'miradas-probe'; allowed: alpha-beta$"):
        require_kind(MIRADAS_PROBE, (ALPHA_BETA,), "planner 'greedy'")
