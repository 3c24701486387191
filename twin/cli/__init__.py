"""The ``rfp-twin`` command line (typer + rich): options in, pipeline out, tables printed.

One module per group of commands: ``plan`` (:mod:`rfp_twin.twin.cli.plan`), ``simulate``,
``render``, ``record``, ``model export`` (:mod:`rfp_twin.twin.cli.run`), ``validate``,
``calibrate-buffer`` (:mod:`rfp_twin.twin.cli.validate`), ``study ...`` (:mod:`rfp_twin.twin.cli.study`),
``coverage`` (:mod:`rfp_twin.twin.cli.coverage`).
Every error is one line and an exit code from :mod:`rfp_twin.twin.cli.console`; nothing
half-written is left behind.
"""
from __future__ import annotations

import typer

from rfp_twin.twin.cli import plan as _plan
from rfp_twin.twin.cli import run as _run
from rfp_twin.twin.cli.coverage import coverage as _coverage
from rfp_twin.twin.cli.console import run_app
from rfp_twin.twin.cli.study import study_app
from rfp_twin.twin.cli.validate import register as _register_validation

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Digital twin of robotic fiber positioner arrays.")


@app.callback()
def _root() -> None:
    """rfp-twin: plan, validate, simulate and render robotic fiber positioner arrays."""


app.command()(_plan.plan)
app.command()(_coverage)
app.command()(_run.simulate)
app.command()(_run.render)
app.command()(_run.record)
app.add_typer(_run.model_app, name="model")
app.add_typer(study_app, name="study")
_register_validation(app)  # `rfp-twin validate RUN`, `rfp-twin calibrate-buffer`


def main() -> None:
    """Console-script entry point (``rfp-twin``)."""
    run_app(app)


__all__ = ["app", "main"]
