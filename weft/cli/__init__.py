"""The `weft` command line: one module per command group, put together here.

- ``weft.cli.local``: validate, run, info, materials (a shot on this machine, into an HDF5 cache)
- ``weft.cli.export``: export (a cache to USD or an OBJ sequence)
- ``weft.cli.service``: up, submit, status, jobs, fetch, cancel, demo (the simulation service)
- ``weft.cli.benchmarks``: ``weft bench ...`` (imports the ``bench`` package when it runs)
- ``weft.cli.regress``: ``weft regress`` (imports the ``regress`` package when it runs)
- ``weft.cli.report``: ``weft report speed-error`` (likewise)

The command modules share ``weft.cli.common`` and never import this package's ``app``.
"""

from __future__ import annotations

import typer

from weft.cli import benchmarks, export, local, regress, report, service

app = typer.Typer(
    name="weft",
    help="weft: implicit cloth simulation for film and animation pipelines.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
app.add_typer(local.app)
app.add_typer(export.app)
app.add_typer(service.app)
app.add_typer(benchmarks.app)
app.add_typer(regress.app)
app.add_typer(report.app)


def main() -> None:  # pragma: no cover
    app()
