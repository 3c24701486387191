"""Tests of the validation package's public API (validation/__init__.py)."""
from __future__ import annotations

import pytest

from rfp_twin import validation
from tests.validation.conftest import python_lines


def test_public_names_resolve_to_the_subpackages_objects():
    from rfp_twin.validation import buffer, checker2d, mesh3d

    homes = {"checker2d": checker2d, "mesh3d": mesh3d, "buffer": buffer}
    assert set(validation.__all__) == {
        "check_trajectory", "CheckReport", "Collision", "validate_trajectory",
        "Check3DReport", "Collision3D", "PairDistance", "LinkModels", "RobotPair",
        "calibrate_buffer", "write_report", "BufferCalibration"}
    for name in validation.__all__:
        obj = getattr(validation, name)
        home = next(h for h in homes.values() if name in h.__all__)
        assert obj is getattr(home, name)
    assert set(validation.__all__) <= set(dir(validation))
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        validation.nothing  # noqa: B018


def test_importing_the_package_loads_no_check_until_a_name_is_used():
    lines = python_lines("import sys; from rfp_twin import validation; "
                         "print(sorted(m for m in sys.modules if m.startswith('rfp_twin.validation.'))); "
                         "validation.check_trajectory; "
                         "print('fcl' in sys.modules, 'rfp_twin.validation.checker2d' in sys.modules)")
    assert lines[-2:] == ["[]", "False True"]
