"""`rfp-twin plan` on the MIRADAS probe-arm preset: kinds refused in one line, run folder."""
from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from rfp_twin.models.errors import KindError
from rfp_twin.twin.cli import app
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration


@pytest.mark.parametrize("algorithm", ["greedy", "markov", "apf", "capf"])
def test_gcmc_and_fields_refuse_the_probe_kind(tmp_path, algorithm):
    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["plan", "--preset", "miradas-probe", "--layout", "miradas-12",
                                 "--algorithm", algorithm, "--out", str(out)])
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert lines == [f"error: planner '{algorithm}' does not support robot kind "
                     "'miradas-probe'; allowed: alpha-beta"]
    assert not out.exists()
    with pytest.raises(KindError, match=f"planner '{algorithm}'"):
        Reconfiguration.from_names("miradas-probe", options=PlanOptions(algorithm=algorithm))


def test_roadmap_plans_the_typical_scenario(tmp_path):
    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["plan", "--preset", "miradas-probe", "--layout", "miradas-12",
                                 "--algorithm", "roadmap", "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert "Table 1 form" in r.output and "2D check clear" in r.output
    assert sorted(p.name for p in out.iterdir()) == ["plan.json", "summary.json", "tables.txt"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["success"] and summary["check2d"]["ok"] and summary["makespan_steps"] <= 19
    plan = json.loads((out / "plan.json").read_text())
    assert sorted(plan, key=int) == [str(i) for i in range(12)]
    assert plan["0"]["theta1"][0] == [180.0, 0.0]             # park, at t = 0


@pytest.mark.parametrize("layout, n_arms", [([], 12), (["--layout", "miradas-6"], 6)])
def test_export_reloads_in_mujoco(tmp_path, layout, n_arms):
    import mujoco

    r = CliRunner().invoke(app, ["model", "export", "--preset", "miradas-probe", *layout,
                                 "--out", str(tmp_path / "m")])
    assert r.exit_code == 0, r.output
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "m" / "rfp-twin.xml"))
    assert (m.neq, m.nu) == (n_arms, 2 * n_arms)           # one loop, two motors per arm
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d)
    assert d.ncon == 0


@pytest.mark.parametrize("changes, words", [
    ({"ds1_mm = 100.0": "ds1_mm = 270.0"}, ["'park_deg'", "ZoA", "allowed"]),   # park in ZoA
    ({"d12_mm = 200.0": "d12_mm = 150.0"}, ["'d12_mm'", "allowed: > d13_mm + d24_mm"]),  # no loop
    ({"ds1_mm = 100.0": "ds1_mm = 400.0", "ds2_mm = 300.0": "ds2_mm = 450.0",   # no pose left
      "d3tip_mm = 420.0": "d3tip_mm = 500.0"}, ["'ds1_mm, ds2_mm'", "allowed: an interval"]),
])
def test_bad_probe_preset_exits_2_in_one_line(tmp_path, changes, words):
    from importlib import resources

    from rfp_twin.models.kinds.bench import MIRADAS_PRESET

    text = (resources.files("rfp_twin.models") / "presets" / f"{MIRADAS_PRESET}.toml").read_text()
    for old, new in changes.items():
        assert old in text
        text = text.replace(old, new)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["plan", "--preset", str(bad), "--algorithm", "roadmap",
                                 "--out", str(out)])
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and str(bad) in lines[0]
    assert all(w in lines[0] for w in words), lines[0]
    assert not out.exists()
