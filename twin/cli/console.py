"""What every ``rfp-twin`` command shares: consoles, exit codes, the one error handler.

Exit codes: 0 done; 2 bad input (one line naming the field, robot and allowed range,
nothing written); 3 incomplete (robots still deadlocked, or study trials left);
4 collision (2D check, 3D validation or simulation contact); 130 interrupted.
"""
from __future__ import annotations

import functools
import sys

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from rfp_twin.models.errors import RfpError

EXIT_BAD_INPUT = 2
EXIT_INCOMPLETE = 3
EXIT_COLLISION = 4
EXIT_INTERRUPTED = 130

console = Console()
err_console = Console(stderr=True)


def command_line() -> str:
    """This process's command line as the user typed it: ``rfp-twin ARGS``."""
    return " ".join(["rfp-twin"] + sys.argv[1:])


def print_error(message: str) -> None:
    """One line on stderr: ``error: MESSAGE`` (markup in the message is not interpreted)."""
    err_console.print(f"[red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)


def fail(message: str, code: int) -> typer.Exit:
    """Print ``message`` as an error line and return the ``typer.Exit`` to raise."""
    print_error(message)
    return typer.Exit(code)


def one_line_errors(fn):
    """Decorator for a command: an :class:`RfpError` becomes one error line and exit 2,
    however the command is mounted (main app, sub-app, or a test's own app)."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except RfpError as exc:
            raise fail(str(exc), EXIT_BAD_INPUT) from None
    return wrapper


def run_app(app: typer.Typer) -> None:
    """Run a typer app as a program: rfp-twin errors raised outside a command (option
    callbacks, sub-app set-up) also end as one line and exit 2."""
    try:
        app()
    except RfpError as exc:
        print_error(str(exc))
        sys.exit(EXIT_BAD_INPUT)


def print_rows(title: str, rows) -> None:
    """A two-column table (quantity, value) of ``rows`` [(str, str), ...] on stdout."""
    from rich.table import Table

    table = Table(title=title)
    table.add_column("quantity")
    table.add_column("value", justify="right")
    for row in rows:
        table.add_row(*row)
    console.print(table)


def progress_bar(label: str, counter: str = "{task.percentage:>3.0f}%") -> Progress:
    """A transient progress bar on stderr: ``LABEL description [bar] COUNTER elapsed``."""
    return Progress(TextColumn(f"[bold]{label}[/] {{task.description}}"), BarColumn(),
                    TextColumn(counter), TimeElapsedColumn(), console=err_console, transient=True)
