"""`weft validate`, `weft run`, `weft info`, `weft materials`: a shot on this machine, into an HDF5
cache, and the material presets it may name."""

from __future__ import annotations

import json
import signal
from enum import Enum
from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from weft.cli.common import console, fail, out, shot_errors

app = typer.Typer()


class LinearSystemChoice(str, Enum):
    fast = "fast"
    reference = "reference"


def _load_scene(shot_path: Path, linear_system: Optional[str] = None) -> Any:
    from weft.shot import load_shot_file
    from weft.solver_setup import resolve_scene

    with shot_errors(shot_path):
        shot = load_shot_file(shot_path)
        if linear_system is not None:  # command-line override of the shot's solver.linear_system
            shot = shot.model_copy(update={"solver": shot.solver.model_copy(update={"linear_system": linear_system})})
        return resolve_scene(shot, shot_path.parent)


@app.command()
def validate(shot: Annotated[Path, typer.Argument(help="Shot file (.json/.yaml)")]) -> None:
    """Check a shot and its assets without simulating."""
    scene = _load_scene(shot)
    out.print(
        f"[green]ok[/] {scene.shot.name}: {len(scene.pieces)} cloth piece(s), {scene.vertex_count} vertices, "
        f"{len(scene.faces)} faces, {len(scene.bodies)} bodies, {scene.frame_count} frames"
    )
    _print_split_bodies(scene)


def _print_split_bodies(scene: Any) -> None:
    from weft.body_shells import split_notes

    for line in split_notes([b.name for b in scene.bodies], scene.solver_bodies):
        console.print(line, markup=False)


@app.command()
def run(
    shot: Annotated[Path, typer.Argument(help="Shot file (.json/.yaml)")],
    output: Annotated[Path, typer.Option("-o", "--output", help="HDF5 cache to write")],
    frames: Annotated[Optional[int], typer.Option("--frames", min=1, help="Only the first N frames")] = None,
    threads: Annotated[int, typer.Option("--threads", min=1, max=256, help="Solver threads")] = 1,
    resume: Annotated[bool, typer.Option("--resume", help="Continue an interrupted cache")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar")] = False,
    linear_system: Annotated[
        Optional[LinearSystemChoice],
        typer.Option("--linear-system", help="Override the shot's solver.linear_system (fast or reference)"),
    ] = None,
) -> None:
    """Simulate a shot into an HDF5 cache."""
    from weft.cache import CacheError
    from weft.runner import FrameRecord, RunInterrupted, ShotRunner, SolverFailure

    scene = _load_scene(shot, linear_system.value if linear_system else None)
    if output.exists() and not resume:
        fail(f"{output} exists; remove it or pass --resume to continue it")
    runner = ShotRunner(scene, output, threads=threads, frames=frames, resume=resume)
    _print_split_bodies(scene)
    if runner.threads_used < threads:
        console.print(f"note: --threads {threads}: this process may run on {runner.threads_used} CPU(s); the solver "
                      f"uses {runner.threads_used} thread(s) (the results are the same for any count)")
    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]}"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=console,
        disable=quiet,
    )

    def on_frame(record: FrameRecord) -> None:
        progress.update(
            task,
            completed=record.index + 1,
            description=f"frame {record.frame}",
            rate=f"{record.wall_seconds:.3f} s/frame",
        )

    # SIGTERM, SIGHUP and Ctrl-C stop the run after the frame in progress: the handler only
    # records the signal and the runner raises RunInterrupted between frames (should_stop), so
    # the cache is closed readable. Raising from the handler itself could land in a weakref
    # callback (h5py's), where Python prints the exception and drops it: the stop was lost. A
    # second signal raises at once (a frame that never ends).
    stop_reason: list[str] = []

    def interrupt(signum: int, _frame: object) -> None:
        name = "SIGINT" if signum == signal.SIGINT else signal.Signals(signum).name
        if stop_reason:
            raise RunInterrupted(name)
        stop_reason.append(name)

    def should_stop() -> bool:
        if stop_reason:
            raise RunInterrupted(stop_reason[0])
        return False

    for signum in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
        signal.signal(signum, interrupt)
    try:
        with progress:
            task = progress.add_task(scene.shot.name, total=runner.frames_total, rate="")
            summary = runner.run(on_frame=on_frame, should_stop=should_stop)
    except (RunInterrupted, KeyboardInterrupt) as exc:
        reason = exc.reason if isinstance(exc, RunInterrupted) else "SIGINT"
        fail(f"stopped by {reason}: {output} is closed with the frames finished so far; continue it with "
             "--resume", code=130)
    except SolverFailure as exc:
        fail(f"solver failed at frame {exc.frame}: {exc.reason} (frames before it are in {output})", code=1)
    except CacheError as exc:
        fail(str(exc))
    _print_summary(output, summary.wall_seconds)


def _substeps_line(info: dict) -> str:
    """Steps taken, with what adaptive substepping did where the cache records it."""
    parts = [f"{info['substeps']} taken"]
    if "halved_substeps" in info:
        parts.append(f"{info['halved_substeps']} halved after a failed attempt")
    if "frames_started_halved" in info:
        parts.append(f"{info['frames_started_halved']} frames started halved for fast bodies")
    if info.get("friction_spreads"):
        parts.append(f"{info['friction_spreads']} with friction spread through the cloth")
    return ", ".join(parts)


def _print_summary(cache: Path, wall_seconds: float) -> None:
    from weft.cache import describe_cache

    info = describe_cache(cache)
    table = Table(title=f"weft: {info['shot_name']}", show_header=False, title_justify="left")
    table.add_row("cache", str(cache))
    table.add_row("status", info["status"])
    table.add_row("frames", f"{info['frames_written']} of {info['frames_planned']}")
    table.add_row("vertices / faces", f"{info['vertices']} / {info['faces']}")
    if "mean_seconds_per_frame" in info:
        m = info["mean_seconds_per_frame"]
        table.add_row(
            "mean s/frame",
            f"build {m['build']:.4f}  solve {m['solve']:.4f}  collision {m['collision']:.4f}  "
            f"GIA {m['gia']:.4f}  total {m['total']:.4f}",
        )
        table.add_row("CG iterations/frame", f"{info['cg_iterations_per_frame']:.1f}")
        table.add_row("unconverged substeps", str(info["unconverged_substeps"]))
        table.add_row("substeps", _substeps_line(info))
    threads = info.get("solver_threads")
    if threads and threads["fewest"] < threads["most"]:
        table.add_row("threads", f"{threads['fewest']}-{threads['most']}: fewer while other processes wanted the "
                                 f"cores (CPU wait up to {threads['max_cpu_wait_share']:.2f} per thread-second)")
    table.add_row("wall time", f"{wall_seconds:.2f} s")
    out.print(table)


@app.command()
def info(
    cache: Annotated[Path, typer.Argument(help="HDF5 cache written by weft")],
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output")] = False,
    recover: Annotated[bool, typer.Option(
        "--recover", help="The cache's writer died (status still 'running'): rewrite its finished frames into a "
        "clean file, status 'interrupted', readable by any HDF5 reader (as h5clear -s); --resume continues it")] = False,
) -> None:
    """Show what a cache holds."""
    from weft.cache import CacheError, describe_cache, recover_cache

    if not cache.is_file():
        fail(f"no such file: {cache}")
    try:
        summary = recover_cache(cache) if recover else describe_cache(cache)
    except CacheError as exc:
        fail(str(exc))
    if summary["status"] == "running" and not as_json:
        console.print("[yellow]status 'running': the cache is being written, or its writer died (then "
                      "`weft info --recover` makes it readable everywhere and `weft run --resume` continues it)[/]")
    if as_json:
        out.print_json(json.dumps(summary))
        return
    summary.pop("shot")
    table = Table(title=f"{cache}", show_header=False, title_justify="left")
    for key, value in summary.items():
        table.add_row(key, json.dumps(value) if isinstance(value, (dict, list)) else str(value))
    out.print(table)


@app.command()
def materials(
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output")] = False,
) -> None:
    """The material presets (`material: {preset: NAME}`): their values and where they come from."""
    from api_schemas.materials import PRESET_FIELDS, PRESETS

    if as_json:
        out.print_json(json.dumps({name: {"fabric": p.fabric, "measured": p.measured, "source": p.source,
                                          **p.values} for name, p in PRESETS.items()}))
        return
    table = Table(title="weft material presets (SI units; fields not listed keep Material's defaults)")
    table.add_column("preset")
    table.add_column("fabric")
    for name in PRESET_FIELDS:
        table.add_column(name, justify="right")
    table.add_column("basis")
    for name, preset in PRESETS.items():
        table.add_row(name, preset.fabric, *(f"{preset.values[f]:.4g}" for f in PRESET_FIELDS),
                      "measured" if preset.measured else "estimate")
    out.print(table)
    for name, preset in PRESETS.items():
        out.print(f"[bold]{name}[/bold]: {preset.source}")
