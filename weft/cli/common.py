"""What the command modules share: the two consoles, failing with a message, shot errors."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import NoReturn

import typer
from rich.console import Console

console = Console(stderr=True)  # progress, errors
out = Console()  # results


def fail(message: str, code: int = 2) -> NoReturn:
    console.print(f"[bold red]error:[/] {message}", highlight=False)
    raise typer.Exit(code)


@contextmanager
def shot_errors(shot_path: Path) -> Iterator[None]:
    """Turn a ShotError or ShotValidationError raised inside into a failure naming the shot file
    and every problem by field path."""
    from weft.shot import ShotError, ShotValidationError

    try:
        yield
    except ShotValidationError as exc:
        fail(f"{shot_path} is not a valid shot:\n" + "\n".join(f"  {e.field}: {e.problem}" for e in exc.errors))
    except ShotError as exc:
        fail(f"{shot_path}: {exc}")
