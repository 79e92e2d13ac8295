"""`weft bench ...`: performance measurements. Each command imports its benchmark from the
`bench` package when it runs (bench is not part of the library)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

app = typer.Typer(name="bench", help="Performance benchmarks.", no_args_is_help=True)


def _sizes(text: str) -> list[int]:
    """`--sizes`: comma-separated positive integers; a clear usage error otherwise."""
    tokens = [s.strip() for s in text.split(",") if s.strip()]
    bad = [t for t in tokens if not t.isdigit() or int(t) < 1]
    if bad:
        raise typer.BadParameter(f"{bad[0]!r} is not a positive integer (give e.g. 16,32,64)", param_hint="--sizes")
    return [int(t) for t in tokens]


@app.command("solver")
def solver(
    threads: Annotated[str, typer.Option("--threads", help="Solver threads: a count, or several and 'all' "
                                                           "(e.g. 1,2,all: one run each, then a table across them)")] = "2",
    json_path: Annotated[Optional[Path], typer.Option("--json", help="Also write every figure as JSON here")] = None,
    quick: Annotated[bool, typer.Option("--quick", help="Two small sheets only (a smoke test)")] = False,
    sizes: Annotated[str, typer.Option("--sizes", help="Sheet sides instead, e.g. 16,32,64 (one frame each)")] = "",
    repeat: Annotated[int, typer.Option("--repeat", min=1, max=20,
                                        help="Timed blocks per size for the two fast paths (median and range of "
                                             "multigrid's speed-up)")] = 1,
) -> None:
    """Fast (block Jacobi and multigrid) vs reference linear system on 10k-640k vertex sheets
    (the seed's Table 1 shape)."""
    from bench.solver_bench import main, parse_thread_counts

    try:
        counts = parse_thread_counts(threads)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--threads") from None
    main(threads=counts[0] if len(counts) == 1 else counts, json_path=json_path, quick=quick,
         sides=_sizes(sizes) or None, repeat=repeat)


@app.command("ccd")
def ccd(
    queries: Annotated[int, typer.Option("--queries", min=1000, help="Randomized queries per kind")] = 100_000,
    sizes: Annotated[str, typer.Option("--sizes", help="Twisting-sheet grid sizes n (n x n vertices)")] = "8,12,16,24",
    frames: Annotated[int, typer.Option("--frames", min=3, help="Frames of the twist (full turn)")] = 121,
    substeps: Annotated[int, typer.Option("--substeps", min=1)] = 2,
    threads: Annotated[int, typer.Option("--threads", min=1, max=256)] = 1,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output")] = False,
) -> None:
    """CCD queries per second and false negatives on the randomized exact-truth set; per-frame
    collision cost against vertex count on the twisting sheet."""
    from bench.ccd import main

    main(queries=queries, sizes=_sizes(sizes), frames=frames, substeps=substeps, threads=threads, as_json=as_json)


@app.command("gia")
def gia(
    sizes: Annotated[str, typer.Option("--sizes", help="Bone-sheet grid sizes n (n x n vertices)")] = "21,41,81,161",
    frames: Annotated[int, typer.Option("--frames", min=1, help="Frames per scaling run")] = 4,
    threads: Annotated[int, typer.Option("--threads", min=1, max=256)] = 2,
    cases: Annotated[bool, typer.Option("--cases/--no-cases", help="Also run the hard cases")] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output")] = False,
) -> None:
    """GIA seconds against vertex count, and GIA's share of the frame on the hard cases. GIA runs
    in a step only while the state may be in intersection (docs/intersection-analysis.md), so
    "frame 1" holds at least one full analysis and "per step" is the average a shot pays."""
    from bench.gia import main

    main(sizes=_sizes(sizes), frames=frames, threads=threads, cases=cases, as_json=as_json)


@app.command("contact", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def contact(ctx: typer.Context) -> None:
    """Contact scenes (drape, sleeve, pinch, thin limb, articulated dress) run by weft and, with
    --peer blender, by Blender cloth in the same run: s/frame, ratio, inside, gaps, strain and
    weft's step breakdown. Options as `python -m bench.contact --help`."""
    from bench.contact import main

    raise typer.Exit(main(list(ctx.args)))


@app.command("tolerance", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def tolerance(ctx: typer.Context) -> None:
    """Speed against error of the CG tolerance: each scene once per tolerance, error against a
    1e-8 run, with the scene's own sensitivity as a floor. Options as `python -m bench.tolerance --help`."""
    from bench.tolerance import main

    raise typer.Exit(main(list(ctx.args)))
