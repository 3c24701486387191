"""Help texts are shown as written: bracketed words ([geometry], [default: ...]) stay."""
from __future__ import annotations

import pytest
from typer.testing import CliRunner

from rfp_twin.twin.cli import app


@pytest.mark.parametrize("command, text", [
    (["validate", "--help"], "whose [geometry] table gives"),
    (["plan", "--help"], "[default: seeded random]"),
    (["unwind", "--help"], "(robot_id,alpha_deg,beta_deg)"),
])
def test_help_keeps_bracketed_words(command, text):
    result = CliRunner().invoke(app, command, terminal_width=400)
    assert result.exit_code == 0
    assert text in " ".join(result.output.split())
