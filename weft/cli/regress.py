"""`weft regress`: the regression scenes submitted to the service and judged against their
references (imports the `regress` package when it runs; regress is not part of the library)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from weft.cli.common import console, fail, out

app = typer.Typer()


@app.command()
def regress(
    scenes: Annotated[str, typer.Option("--scenes", help="Comma-separated scene names (default: all)")] = "",
    server: Annotated[Optional[str], typer.Option(
        "--server", envvar="WEFT_SERVER", help="API URL of a running service (default: start a local stack)")] = None,
    local: Annotated[bool, typer.Option("--local", help="Run the scenes in this process instead of the service")] = False,
    workers: Annotated[int, typer.Option("--workers", min=1, max=16, help="Workers of the local stack")] = 2,
    threads: Annotated[int, typer.Option("--threads", min=1, max=256, help="Solver threads (local runs, metrics)")] = 2,
    output: Annotated[Path, typer.Option("-o", "--out", help="Directory for regress.md, regress.xml, regress.json")] = Path("out/regress"),
    update_references: Annotated[bool, typer.Option(
        "--update-references", help="Rewrite the scenes' references (converged runs, here) instead of judging")] = False,
    list_scenes: Annotated[bool, typer.Option("--list", help="List the scenes and exit")] = False,
) -> None:
    """Run the regression scenes (scenes/regression/) and judge them against their references:
    position error, bodies, intersections, strain, and load-independent counts. Exit status 1 when
    any scene regresses."""
    from regress import main as driver
    from regress.runs import unknown_scenes

    if list_scenes:
        for name in driver.all_scenes():
            out.print(name)
        return
    names = [s.strip() for s in scenes.split(",") if s.strip()] or driver.all_scenes()
    unknown = unknown_scenes(names)
    if unknown:
        fail(f"--scenes: unknown scene(s) {', '.join(unknown)}; known: {', '.join(driver.all_scenes())}")
    if local and server:
        fail("--local and --server exclude each other")

    def log(message: str) -> None:
        console.print(f"[dim]{message}[/]")

    if update_references:
        typer.echo(driver.update_references(names, threads, log))
        return
    passed, summary, paths = driver.main(names, "local" if local else "service", server, workers, threads, output, log)
    typer.echo(summary)  # plain text: Markdown tables must not be wrapped to a terminal's width
    typer.echo(f"reports: {', '.join(str(p) for p in paths.values())}")
    if not passed:
        raise typer.Exit(1)
