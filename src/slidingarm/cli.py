"""The ``slidingarm`` command line: thin verbs that parse, validate, call the library, report."""

from __future__ import annotations

import typer

from slidingarm._version import __version__

app = typer.Typer(
    name="slidingarm",
    help="Sliding-mode control of robot arms: simulate, compare and reproduce the FTSMC study.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _version_callback(value: bool) -> None:
    if value:
        typer.echo(f"slidingarm {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False,
        "--version",
        callback=_version_callback,
        is_eager=True,
        help="Print the version and exit.",
    ),
) -> None:
    """Sliding-mode control of robot arms."""


def main() -> None:
    """Entry point of the ``slidingarm`` console script."""
    app()
