"""`weft export CACHE.h5 --usd OUT.usd | --obj-sequence DIR`: a cache as files other tools read
(``weft.export``)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated

import typer

from weft.cli.common import fail, out

app = typer.Typer()


def frame_range(text: str | None) -> range | None:
    """'A:B' -> frames A to B inclusive."""
    if text is None:
        return None
    match = re.fullmatch(r"\s*(-?\d+)\s*:\s*(-?\d+)\s*", text)
    if not match:
        fail(f"--frames {text!r}: expected FIRST:LAST, e.g. 1:48")
    first, last = int(match.group(1)), int(match.group(2))
    if last < first:
        fail(f"--frames {text!r}: the last frame comes before the first")
    return range(first, last + 1)


@app.command()
def export(
    cache: Annotated[Path, typer.Argument(help="HDF5 cache written by weft")],
    usd: Annotated[Path | None, typer.Option("--usd", help="Write a USD stage (.usd/.usda/.usdc)")] = None,
    obj_sequence: Annotated[Path | None, typer.Option("--obj-sequence", help="Write one OBJ per frame into DIR")]
    = None,
    frames: Annotated[str | None, typer.Option("--frames", help="FIRST:LAST frame numbers, inclusive")] = None,
    velocities: Annotated[bool, typer.Option("--velocities/--no-velocities", help="USD: time-sampled velocities")]
    = True,
    bodies: Annotated[bool, typer.Option("--bodies/--no-bodies", help="USD: the bodies, when the cache keeps their "
                                                                      "motion (outputs.body_motion)")] = True,
) -> None:
    """Export a cache's cloth to USD or an OBJ sequence (finished frames only)."""
    from weft.export import ExportError, export_obj_sequence, export_usd

    if (usd is None) == (obj_sequence is None):
        fail("give one of --usd OUT.usd or --obj-sequence DIR")
    selection = frame_range(frames)
    try:
        if usd is not None:
            summary = export_usd(cache, usd, velocities=velocities, bodies=bodies, frames=selection)
        else:
            summary = export_obj_sequence(cache, obj_sequence, frames=selection)  # type: ignore[arg-type]
    except ExportError as exc:
        fail(str(exc))
    out.print(f"wrote {summary.path}: frames {summary.frames[0]}-{summary.frames[1]} ({summary.frame_count}), "
              f"pieces {', '.join(summary.pieces)}")
