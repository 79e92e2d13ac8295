"""Parse and validate a shot document.

Every problem found is reported as a ShotError whose ``field`` is the path of the offending field
in the shot (``cloth[0].mesh.faces[12]``), so the CLI and the HTTP API can say exactly what is
wrong. Schema checks come from the pydantic models in ``api_schemas``; checks that need the asset
files are in ``weft.assets`` and ``weft.solver_setup``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from api_schemas import Shot


class ShotError(ValueError):
    """One problem with a shot, located by its field path."""

    def __init__(self, field: str, problem: str) -> None:
        super().__init__(f"{field}: {problem}")
        self.field = field
        self.problem = problem


class ShotValidationError(ValueError):
    """Several problems at once (from schema validation)."""

    def __init__(self, errors: list[ShotError]) -> None:
        super().__init__("; ".join(str(e) for e in errors))
        self.errors = errors


def format_location(loc: tuple[Any, ...]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out or "shot"


def parse_shot(document: dict[str, Any]) -> Shot:
    """Validate a shot document; raise ShotValidationError listing every schema problem."""
    try:
        return Shot.model_validate(document)
    except ValidationError as exc:
        errors = []
        for err in exc.errors(include_url=False):
            # Drop pydantic's union-branch tags (e.g. 'list[...]', 'ArrayAsset') from the path.
            loc = tuple(p for p in err["loc"] if isinstance(p, int) or not _is_type_tag(str(p)))
            message = err["msg"].removeprefix("Value error, ")
            errors.append(ShotError(format_location(loc), message))
        raise ShotValidationError(errors) from None


def _is_type_tag(part: str) -> bool:
    return "[" in part or part[:1].isupper() or part in {"function-after", "function-before"}


def load_shot_file(path: str | Path) -> Shot:
    """Read a shot from a .json, .yaml or .yml file."""
    path = Path(path)
    if not path.is_file():
        raise ShotError("shot", f"file not found: {path}")
    text = path.read_text(encoding="utf-8")
    try:
        if path.suffix.lower() == ".json":
            document = json.loads(text)
        elif path.suffix.lower() in {".yaml", ".yml"}:
            document = yaml.safe_load(text)
        else:
            raise ShotError("shot", f"unknown shot file type '{path.suffix}' (use .json, .yaml or .yml)")
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        raise ShotError("shot", f"cannot parse {path.name}: {exc}") from None
    if not isinstance(document, dict):
        raise ShotError("shot", "the document must be a mapping of fields")
    return parse_shot(document)
