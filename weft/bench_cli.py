"""`weft bench ...`: performance measurements (registered into the main app by weft/cli.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

bench_app = typer.Typer(name="bench", help="Performance benchmarks.", no_args_is_help=True)


@bench_app.command("solver")
def solver(
    threads: Annotated[int, typer.Option("--threads", min=1, max=256, help="Solver threads")] = 2,
    json_path: Annotated[Optional[Path], typer.Option("--json", help="Also write every figure as JSON here")] = None,
    quick: Annotated[bool, typer.Option("--quick", help="Two small sheets only (a smoke test)")] = False,
) -> None:
    """Fast vs reference linear system on 10k-640k vertex sheets (the seed's Table 1 shape)."""
    from bench.solver_bench import main

    main(threads=threads, json_path=json_path, quick=quick)
