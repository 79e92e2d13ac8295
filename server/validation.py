"""Shot validation for submissions: parse, check limits, resolve every asset. Each problem is an
``ApiError`` (4xx) naming its field."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from api_schemas import Shot
from server.errors import ApiError
from server.uploads import normalize_asset_path
from weft.jobstore import ServiceSettings
from weft.assets import asset_paths, shot_hash
from weft.shot import ShotError, ShotValidationError, parse_shot
from weft.solver_setup import resolve_scene


def check_index_sizes(shot: Shot) -> None:
    """Vertex indices must fit the solver's int32 (the schema accepts any integer)."""
    limit = 2**31

    def check(values: Any, field: str) -> None:
        for k, value in enumerate(values or []):
            items = value if isinstance(value, tuple | list) else (value,)
            if any(not -limit <= v < limit for v in items):
                raise ShotError(f"{field}[{k}]", f"vertex index {max(items, key=abs)} is out of range")

    for i, piece in enumerate(shot.cloth):
        check(piece.mesh.faces, f"cloth[{i}].mesh.faces")
        for j, pin in enumerate(piece.pins):
            check(pin.vertices, f"cloth[{i}].pins[{j}].vertices")
    for i, body in enumerate(shot.bodies):
        check(body.mesh.faces, f"bodies[{i}].mesh.faces")


def validate_shot(body: bytes, assets: Path, uploaded: set[str], settings: ServiceSettings) -> tuple[Shot, int]:
    """Parse and fully resolve a shot (assets included): the shot and its cloth vertex count."""
    try:
        document = json.loads(body)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        problem = "nested too deeply" if isinstance(exc, RecursionError) else str(exc)
        raise ApiError(400, f"shot is not valid JSON: {problem}", [{"field": "shot", "problem": problem}]) from None
    if not isinstance(document, dict):
        raise ApiError(422, "the shot must be a JSON object", [{"field": "shot", "problem": "not an object"}])
    try:
        shot = parse_shot(document)
        check_index_sizes(shot)
        if shot.frame_count > settings.max_frames:
            raise ShotError("frame_range", f"{shot.frame_count} frames exceeds the limit of {settings.max_frames}")
        referenced = {normalize_asset_path(path) for path in asset_paths(shot)}
        extra = sorted(uploaded - referenced)
        if extra:
            raise ApiError(400, f"uploaded file {extra[0]!r} is not referenced by the shot",
                           [{"field": "assets", "problem": f"unreferenced file {extra[0]!r}"}])
        vertices = sum(len(p.mesh.vertices or []) for p in shot.cloth)
        if vertices > settings.max_vertices:
            raise ShotError("cloth", f"{vertices} vertices exceeds the limit of {settings.max_vertices}")
        scene = resolve_scene(shot, assets)
    except ShotValidationError as exc:
        errors = [{"field": e.field, "problem": e.problem} for e in exc.errors]
        raise ApiError(422, f"invalid shot: {exc}", errors) from None
    except ShotError as exc:
        raise ApiError(422, f"invalid shot: {exc}", [{"field": exc.field, "problem": exc.problem}]) from None
    if scene.vertex_count > settings.max_vertices:
        raise ApiError(422, f"invalid shot: cloth: {scene.vertex_count} vertices exceeds the limit of "
                       f"{settings.max_vertices}", [{"field": "cloth", "problem": "too many vertices"}])
    cost = scene.vertex_count * max(shot.frame_count - 1, 0) * shot.substeps
    if cost > settings.max_cost:
        problem = (f"{scene.vertex_count} vertices x {shot.frame_count - 1} simulated frames x {shot.substeps} "
                   f"substeps = {cost:.3g} vertex-substeps exceeds this service's budget of {settings.max_cost:.3g} "
                   "per job (fewer frames or substeps, or split the shot)")
        raise ApiError(422, f"invalid shot: {problem}", [{"field": "substeps", "problem": problem},
                                                         {"field": "frame_range", "problem": problem}])
    return shot, scene.vertex_count


def validate_and_hash(body: bytes, assets: Path, uploaded: set[str],
                      settings: ServiceSettings) -> tuple[Shot, int, str]:
    """validate_shot, then the request's hash (SHA-256 of the shot and its assets' bytes, for
    Idempotency-Key): both in the bounded validation process, never in the API's."""
    shot, vertices = validate_shot(body, assets, uploaded, settings)
    return shot, vertices, shot_hash(shot, assets)
