"""Tests of rfp_twin.models.mjcf.options: names, servo parameters and build options."""
from __future__ import annotations

import math

import mujoco
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.mjcf import ModelOptions, ServoParams, collect_mujoco_warnings, fiducial_name, robot_name
from rfp_twin.models.mjcf.options import servo_for
from rfp_twin.models.robot import load_spec


def test_servo_params_from_the_actuators_table_and_errors():
    servo = ServoParams.from_tables({"actuators": {"servo_bandwidth_hz": 5.0,
                                                   "torque_limit_mNm": 20.0}})
    assert servo.bandwidth_hz == 5.0 and servo.torque_limit_mNm == 20.0
    kp, kv = servo.gains(300.0)
    assert kp == pytest.approx(300.0 * (2 * math.pi * 5.0) ** 2)
    assert kv == pytest.approx(2.0 * math.sqrt(kp * 300.0))
    with pytest.raises(SpecError, match="torque_limit_mNm"):
        ServoParams.from_tables({"actuators": {"torque_limit_mNm": -1.0}}, "x.toml")
    with pytest.raises(SpecError, match="timestep_s"):
        ModelOptions(timestep_s=1.0)
    with pytest.raises(SpecError, match="integrator"):
        ModelOptions(integrator="verlet")


def test_servo_for_reads_the_actuators_table_of_the_spec_file(tmp_path):
    path = tmp_path / "slow.toml"
    path.write_text('extends = "sdss-v"\n[actuators]\nservo_bandwidth_hz = 4.0\n')
    assert servo_for(load_spec(path)).bandwidth_hz == 4.0
    assert servo_for(load_spec("sdss-v")) == ServoParams()
    assert servo_for(load_spec(path).with_overrides(source="<memory>")) == ServoParams()
    path.write_text('extends = "sdss-v"\n[actuators]\narmature_kg_mm2 = 0\n')
    with pytest.raises(SpecError, match=r"slow\.toml: \[actuators\] field 'armature_kg_mm2'"):
        servo_for(load_spec(path))


def test_body_names():
    assert (robot_name(12), robot_name(12, "beta"), fiducial_name(3)) == ("r12", "r12_beta", "fid3")


def test_warning_collector_restores_the_previous_handler():
    before = mujoco.get_mju_user_warning()
    with collect_mujoco_warnings() as messages:
        assert mujoco.get_mju_user_warning() is not before
        assert messages == []
    assert mujoco.get_mju_user_warning() is before
