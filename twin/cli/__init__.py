"""The ``rfp-twin`` command line (typer + rich): options in, pipeline out, tables printed.

One module per group of commands: ``plan`` (:mod:`rfp_twin.twin.cli.plan`), ``assign``
(:mod:`rfp_twin.twin.cli.assign`), ``simulate``,
``render``, ``record``, ``model export`` (:mod:`rfp_twin.twin.cli.run`), ``validate``,
``calibrate-buffer`` (:mod:`rfp_twin.twin.cli.validate`), ``study ...`` (:mod:`rfp_twin.twin.cli.study`),
``coverage`` (:mod:`rfp_twin.twin.cli.coverage`), ``unwind``, ``explode``
(:mod:`rfp_twin.twin.cli.recovery`).
Every error is one line and an exit code from :mod:`rfp_twin.twin.cli.console`; nothing
half-written is left behind.
"""
from __future__ import annotations

import gc

import typer

from rfp_twin.twin.cli import plan as _plan
from rfp_twin.twin.cli.assign import assign as _assign
from rfp_twin.twin.cli import recovery as _recovery
from rfp_twin.twin.cli import run as _run
from rfp_twin.twin.cli.coverage import coverage as _coverage
from rfp_twin.twin.cli.console import run_app
from rfp_twin.twin.cli.study import study_app
from rfp_twin.twin.cli.validate import register as _register_validation

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  rich_markup_mode=None,
                  help="Digital twin of robotic fiber positioner arrays.")


@app.callback()
def _root() -> None:
    """rfp-twin: plan, validate, simulate and render robotic fiber positioner arrays."""


app.command()(_plan.plan)
app.command()(_assign)
app.command()(_recovery.unwind)
app.command()(_recovery.explode)
app.command()(_coverage)
app.command()(_run.simulate)
app.command()(_run.render)
app.command()(_run.record)
app.add_typer(_run.model_app, name="model")
app.add_typer(study_app, name="study")
_register_validation(app)  # `rfp-twin validate RUN`, `rfp-twin calibrate-buffer`


#: Allocations between two young-generation collections (Python's default: 700). A command
#: imports numba and scipy (~150k objects) and builds many small arrays; at the default, a
#: `plan` spends ~0.2 s in the collector. Cycles are still collected, just less often.
GC_YOUNG_THRESHOLD = 10_000


def main() -> None:
    """Console-script entry point (``rfp-twin``).

    The process ends when the command returns: every file is written and closed by then,
    so the objects left are frozen (``gc.freeze``) and the interpreter's exit does not walk
    them all once more (~0.3 s after a `plan`). Tests run ``app`` directly, not this."""
    gc.set_threshold(GC_YOUNG_THRESHOLD, *gc.get_threshold()[1:])
    try:
        run_app(app)
    finally:
        gc.freeze()


__all__ = ["app", "main"]
