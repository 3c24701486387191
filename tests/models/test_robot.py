"""Tests of rfp_twin.models.robot: presets, TOML loading/validation, derived quantities.

Facts: Sayres 2021 Sect. 3-4 (7.4 / 15 mm arms, 22.4 mm pitch, 30 deg/s, fold (10, 170),
buffer 2.5 mm = Eq. 12, neighbour reach Eq. 4); SDSS-V coordio/kaiju 1.4.1 (production segment end
16.2 - (sqrt(cb^2 + 0.3^2) - 0.55) mm, 14.73 mm at cb = 2.0); Makarem 2014 (DESI 3 + 3 mm,
10.4 mm pitch).
"""
from __future__ import annotations

import math
from importlib import resources
from pathlib import Path

import pytest

from rfp_twin.models.errors import RfpError, SpecError
from rfp_twin.models.robot import (RobotSpec, list_presets, load_spec, load_tables,
                          sdss_production_segment_end, spec_from_dict, spec_origin)

# A complete, valid spec file; tests break one thing at a time.
VALID = """\
[robot]
name = "test-robot"
description = "unit test robot"
alpha_length_mm = 7.4
beta_length_mm = 15.0
pitch_mm = 22.4
alpha_limits_deg = [0.0, 360.0]
beta_limits_deg = [0.0, 360.0]
max_speed_deg_s = [30.0, 30.0]
max_accel_deg_s2 = [45.0, 45.0]
fold_deg = [10.0, 170.0]
angular_error_deg = [1.5, 1.48]

[collision]
buffer_mm = 2.5
segment_start_mm = 0.0
segment_end_mm = 15.0
fiducial_buffer_mm = 1.5
"""


def write(tmp_path: Path, text: str, name: str = "spec.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def replace_line(key: str, new_line: str | None, text: str = VALID) -> str:
    """VALID with the line starting with ``key =`` replaced (or removed if None)."""
    lines = text.splitlines()
    hits = [i for i, ln in enumerate(lines) if ln.split("=")[0].strip() == key]
    assert len(hits) == 1, key
    if new_line is None:
        del lines[hits[0]]
    else:
        lines[hits[0]] = new_line
    return "\n".join(lines) + "\n"


# -- presets -----------------------------------------------------------------------
def test_list_presets_contains_builtins():
    names = list_presets()
    assert names == sorted(names)
    assert {"sdss-v", "sdss-v-production", "desi"} <= set(names)


@pytest.mark.parametrize("name", list_presets())
def test_every_preset_loads(name):
    spec = load_spec(name)
    assert isinstance(spec, RobotSpec)
    assert spec.name == name
    assert name in spec.source
    lo, hi = spec.patrol_annulus_mm
    assert 0 <= lo < hi == pytest.approx(spec.alpha_length_mm + spec.beta_length_mm)
    assert spec.segment_end() >= spec.segment_start_mm


def test_sdss_v_values():
    s = load_spec("sdss-v")
    assert s.alpha_length_mm == 7.4
    assert s.beta_length_mm == 15.0
    assert s.pitch_mm == 22.4
    assert s.max_speed_deg_s == (30.0, 30.0)
    assert s.fold_deg == (10.0, 170.0)
    assert s.buffer_mm == 2.5
    assert s.segment_start_mm == 0.0 and s.segment_end() == 15.0
    assert s.reach_mm == pytest.approx(22.4)
    assert s.patrol_annulus_mm == pytest.approx((7.6, 22.4))
    assert load_spec() == s  # default preset


def test_desi_values():
    d = load_spec("desi")
    assert (d.alpha_length_mm, d.beta_length_mm, d.pitch_mm) == (3.0, 3.0, 10.4)
    assert d.patrol_annulus_mm == (0.0, 6.0)


def test_production_segment_end_at_2mm():
    assert sdss_production_segment_end(2.0) == pytest.approx(14.73, abs=0.005)
    p = load_spec("sdss-v-production")
    assert p.buffer_mm == 2.0
    assert p.segment_end() == pytest.approx(14.73, abs=0.005)
    assert p.segment_end(2.0) == pytest.approx(14.73, abs=0.005)


@pytest.mark.parametrize("cb", [0.5, 1.5, 2.5, 3.5])
def test_production_segment_end_formula(cb):
    expected = 16.2 - (math.sqrt(cb ** 2 + 0.3 ** 2) - 0.55)
    p = load_spec("sdss-v-production")
    assert p.segment_end(cb) == pytest.approx(expected, abs=1e-12)
    assert sdss_production_segment_end(cb) == pytest.approx(expected, abs=1e-12)
    # the paper-geometry preset has a fixed segment end whatever the buffer
    assert load_spec("sdss-v").segment_end(cb) == 15.0


def test_production_extends_sdss_v():
    base, prod = load_spec("sdss-v"), load_spec("sdss-v-production")
    for f in ("alpha_length_mm", "beta_length_mm", "pitch_mm", "alpha_limits_deg",
              "beta_limits_deg", "fold_deg", "angular_error_deg"):
        assert getattr(prod, f) == getattr(base, f), f
    # production keeps fiducials 3 mm away (kaiju's fiducial buffer), the paper preset 1.5
    assert (prod.fiducial_buffer_mm, base.fiducial_buffer_mm) == (3.0, 1.5)
    assert "extends" not in load_tables("sdss-v-production")


@pytest.mark.parametrize("cb", [1.5, 2.5, 3.5])
def test_neighbour_reach_eq4(cb):
    s = load_spec("sdss-v")
    assert s.neighbour_reach_mm(cb) == pytest.approx(2 * (7.4 + 15.0 + cb), abs=1e-12)
    assert s.neighbour_reach_mm() == pytest.approx(2 * (7.4 + 15.0 + 2.5), abs=1e-12)


def test_step_seconds():
    assert load_spec("sdss-v").step_seconds(0.3) == pytest.approx(0.01)
    assert load_spec("desi").step_seconds(1.2) == pytest.approx(0.01)  # slower axis 120 deg/s


# -- loading user files ----------------------------------------------------------------
def test_valid_file_loads(tmp_path):
    path = write(tmp_path, VALID)
    spec = load_spec(path)
    assert spec.name == "test-robot"
    assert spec.source == str(path)
    assert spec == load_spec("sdss-v").with_overrides(name="test-robot",
                                                       description="unit test robot")
    assert load_spec(str(path)) == spec


def test_integer_values_become_floats(tmp_path):
    text = replace_line("pitch_mm", "pitch_mm = 22")
    text = replace_line("fold_deg", "fold_deg = [10, 170]", text)
    spec = load_spec(write(tmp_path, text))
    assert spec.pitch_mm == 22.0 and isinstance(spec.pitch_mm, float)
    assert spec.fold_deg == (10.0, 170.0)
    assert all(isinstance(v, float) for v in spec.fold_deg)


def test_description_is_optional(tmp_path):
    assert load_spec(write(tmp_path, replace_line("description", None))).description == ""


def assert_spec_error(exc: pytest.ExceptionInfo, *needles: str, allowed: bool = True) -> None:
    msg = str(exc.value)
    assert "\n" not in msg, msg
    for needle in needles:
        assert needle in msg, (needle, msg)
    if allowed:
        assert "allowed" in msg, msg


def test_malformed_toml(tmp_path):
    path = write(tmp_path, VALID + "this is = = not toml\n")
    with pytest.raises(SpecError) as exc:
        load_spec(path)
    assert "malformed TOML" in str(exc.value)
    assert str(path) in str(exc.value)


@pytest.mark.parametrize("table", ["robot", "collision"])
def test_missing_table(tmp_path, table):
    text = VALID.split("[collision]")[0] if table == "collision" else \
        "[collision]" + VALID.split("[collision]")[1]
    with pytest.raises(SpecError) as exc:
        load_spec(write(tmp_path, text))
    assert_spec_error(exc, f"[{table}]", allowed=False)


@pytest.mark.parametrize("field", ["alpha_length_mm", "fold_deg", "buffer_mm", "segment_end_mm",
                                   "name"])
def test_missing_field(tmp_path, field):
    with pytest.raises(SpecError) as exc:
        load_spec(write(tmp_path, replace_line(field, None)))
    assert_spec_error(exc, f"'{field}'", allowed=False)


def test_unknown_field(tmp_path):
    with pytest.raises(SpecError) as exc:
        load_spec(write(tmp_path, VALID.replace("[collision]\n", "[collision]\nbufer_mm = 2.0\n")))
    assert_spec_error(exc, "bufer_mm", "[collision]", "buffer_mm")


def test_unknown_table(tmp_path):
    with pytest.raises(SpecError) as exc:
        load_spec(write(tmp_path, VALID + "[robto]\nx = 1\n"))
    assert_spec_error(exc, "robto")


# (field, replacement line, text that must appear in the message)
BAD_VALUES = [
    ("alpha_length_mm", "alpha_length_mm = -7.4", "alpha_length_mm"),
    ("beta_length_mm", "beta_length_mm = 0.0", "beta_length_mm"),
    ("pitch_mm", "pitch_mm = nan", "pitch_mm"),
    ("buffer_mm", "buffer_mm = nan", "buffer_mm"),
    ("buffer_mm", "buffer_mm = inf", "buffer_mm"),
    ("buffer_mm", "buffer_mm = -1.0", "buffer_mm"),
    ("buffer_mm", 'buffer_mm = "2.5"', "buffer_mm"),
    ("segment_start_mm", "segment_start_mm = true", "segment_start_mm"),
    ("fold_deg", "fold_deg = [10.0, nan]", "fold_deg[beta]"),
    ("fold_deg", "fold_deg = [10.0, 170.0, 0.0]", "fold_deg"),
    ("fold_deg", "fold_deg = [10.0]", "fold_deg"),
    ("max_speed_deg_s", "max_speed_deg_s = 30.0", "max_speed_deg_s"),
    ("max_speed_deg_s", "max_speed_deg_s = [30.0, -30.0]", "max_speed_deg_s[beta]"),
    ("alpha_limits_deg", "alpha_limits_deg = [360.0, 0.0]", "alpha_limits_deg"),
    ("beta_limits_deg", "beta_limits_deg = [90.0, 90.0]", "beta_limits_deg"),
    ("fold_deg", "fold_deg = [-10.0, 170.0]", "fold_deg[alpha]"),
    ("beta_limits_deg", "beta_limits_deg = [0.0, 160.0]", "fold_deg[beta]"),
    ("segment_end_mm", 'segment_end_mm = "sdss-prod"', "segment_end_mm"),
    ("segment_start_mm", "segment_start_mm = 16.0", "segment_end_mm"),
    ("angular_error_deg", "angular_error_deg = [1.5, 91.0]", "angular_error_deg[beta]"),
    ("name", 'name = ""', "name"),
]


@pytest.mark.parametrize("key, line, needle", BAD_VALUES,
                         ids=[f"{k}:{ln.split('=', 1)[1].strip()}" for k, ln, _ in BAD_VALUES])
def test_bad_value_names_field_and_allowed(tmp_path, key, line, needle):
    path = write(tmp_path, replace_line(key, line))
    with pytest.raises(SpecError) as exc:
        load_spec(path)
    assert_spec_error(exc, f"'{needle}'", str(path))


def test_spec_error_is_rfp_error():
    assert issubclass(SpecError, RfpError)


def test_unknown_preset():
    with pytest.raises(SpecError) as exc:
        load_spec("sdss-vi")
    assert_spec_error(exc, "sdss-vi", "sdss-v", "desi")


def test_missing_file(tmp_path):
    path = tmp_path / "nope.toml"
    with pytest.raises(SpecError) as exc:
        load_spec(path)
    assert_spec_error(exc, str(path), "not found", allowed=False)


def test_directory_is_not_a_spec(tmp_path):
    with pytest.raises(SpecError):
        load_spec(tmp_path)


# -- extends ---------------------------------------------------------------------------
def test_extends_preset_overrides_fields(tmp_path):
    path = write(tmp_path, 'extends = "sdss-v"\n[robot]\nname = "wide"\n'
                           "[collision]\nbuffer_mm = 3.5\n")
    spec = load_spec(path)
    assert spec.name == "wide" and spec.buffer_mm == 3.5
    assert spec.alpha_length_mm == 7.4 and spec.fold_deg == (10.0, 170.0)
    assert spec.source == str(path)


def test_extends_file_chain(tmp_path):
    base = write(tmp_path, VALID, "base.toml")
    mid = write(tmp_path, f'extends = "{base}"\n[robot]\nname = "mid"\npitch_mm = 25.0\n',
                "mid.toml")
    top = write(tmp_path, f'extends = "{mid}"\n[collision]\nbuffer_mm = 3.0\n', "top.toml")
    spec = load_spec(top)
    assert (spec.name, spec.pitch_mm, spec.buffer_mm, spec.beta_length_mm) == \
        ("mid", 25.0, 3.0, 15.0)


def test_extends_values_are_validated(tmp_path):
    path = write(tmp_path, 'extends = "sdss-v"\n[collision]\nbuffer_mm = -2.0\n')
    with pytest.raises(SpecError) as exc:
        load_spec(path)
    assert_spec_error(exc, "'buffer_mm'")


def test_extends_cycle(tmp_path):
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    write(tmp_path, f'extends = "{b}"\n[robot]\nname = "a"\n', "a.toml")
    write(tmp_path, f'extends = "{a}"\n[robot]\nname = "b"\n', "b.toml")
    with pytest.raises(SpecError) as exc:
        load_spec(a)
    assert_spec_error(exc, "'extends'", "cycle", allowed=False)


def test_extends_self(tmp_path):
    a = tmp_path / "self.toml"
    write(tmp_path, f'extends = "{a}"\n' + VALID, "self.toml")
    with pytest.raises(SpecError) as exc:
        load_spec(a)
    assert "'extends'" in str(exc.value) and "cycle" in str(exc.value)


def test_extends_not_a_string(tmp_path):
    with pytest.raises(SpecError) as exc:
        load_spec(write(tmp_path, "extends = 3\n" + VALID))
    assert_spec_error(exc, "'extends'")


def test_extends_unknown_preset(tmp_path):
    with pytest.raises(SpecError) as exc:
        load_spec(write(tmp_path, 'extends = "no-such-robot"\n' + VALID))
    assert_spec_error(exc, "no-such-robot")


# -- spec_from_dict / with_overrides ----------------------------------------------------
def test_spec_from_dict_roundtrip():
    tables = load_tables("sdss-v")
    spec = spec_from_dict(tables, source="dict")
    assert spec == load_spec("sdss-v") and spec.source == "dict"
    bad = {**tables, "collision": {**tables["collision"], "segment_end_mm": 1000.5}}
    with pytest.raises(SpecError, match=r"'segment_end_mm'.*allowed"):
        spec_from_dict(bad, source="dict")


def test_with_overrides_revalidates():
    s = load_spec("sdss-v")
    t = s.with_overrides(buffer_mm=1.5)
    assert t.buffer_mm == 1.5 and s.buffer_mm == 2.5
    with pytest.raises(SpecError) as exc:
        s.with_overrides(buffer_mm=-1.0)
    assert_spec_error(exc, "'buffer_mm'")
    with pytest.raises(SpecError) as exc:
        s.with_overrides(fold_deg=(10.0, 400.0))
    assert_spec_error(exc, "fold_deg[beta]")
    with pytest.raises(SpecError) as exc:
        s.with_overrides(fold_deg=[10.0, 170.0])  # a list is not a pair tuple
    assert_spec_error(exc, "'fold_deg'")


def test_with_overrides_unknown_field():
    with pytest.raises(SpecError, match="bufer_mm"):
        load_spec("sdss-v").with_overrides(bufer_mm=2.0)


def test_spec_is_frozen():
    s = load_spec("sdss-v")
    with pytest.raises(AttributeError):
        s.buffer_mm = 3.0  # type: ignore[misc]


# -- where a spec came from ------------------------------------------------------------
def test_folder_named_like_a_preset_does_not_hide_it(tmp_path, monkeypatch):
    (tmp_path / "sdss-v").mkdir()
    monkeypatch.chdir(tmp_path)
    assert load_spec("sdss-v").alpha_length_mm == 7.4


def test_relative_extends_is_resolved_from_the_file(tmp_path, monkeypatch):
    d = tmp_path / "specs"
    d.mkdir()
    (d / "base.toml").write_text(_sdss_text())
    (d / "mine.toml").write_text('extends = "base.toml"\n[robot]\npitch_mm = 20.0\n')
    monkeypatch.chdir(tmp_path)
    spec = load_spec(d / "mine.toml")
    assert spec.pitch_mm == 20.0 and spec.alpha_length_mm == 7.4


def _sdss_text() -> str:
    return (resources.files("rfp_twin.models") / "presets" / "sdss-v.toml").read_text()


def test_spec_origin_names_the_preset_or_file(tmp_path):
    assert spec_origin(load_spec("desi")) == "desi"
    path = write(tmp_path, VALID)
    spec = load_spec(path)
    assert spec_origin(spec) == str(path)
    assert load_tables(spec_origin(spec))["robot"]["name"] == "test-robot"
    assert spec_origin(spec.with_overrides(source="<memory>")) is None
    path.unlink()
    assert spec_origin(spec) is None                                # the file is gone


def test_production_speed_and_path_delay_are_the_instruments():
    paper, prod, cold = (load_spec(n) for n in ("sdss-v", "sdss-v-production",
                                                 "sdss-v-production-cold"))
    rpm = lambda deg_s: deg_s * 60.0 / 360.0
    # motor 2000 RPM (cold 1000 RPM) through the 1024:1 gearbox, both axes
    assert [rpm(v) for v in prod.max_speed_deg_s] == pytest.approx([2000 / 1024] * 2)
    assert [rpm(v) for v in cold.max_speed_deg_s] == pytest.approx([1000 / 1024] * 2)
    assert (prod.path_delay_s, cold.path_delay_s, paper.path_delay_s) == (1.0, 1.0, 0.0)
    assert paper.max_speed_deg_s == (30.0, 30.0)           # Sayres 2021 Sect. 4.1
    with pytest.raises(SpecError, match="path_delay_s"):
        prod.with_overrides(path_delay_s=-1.0)
