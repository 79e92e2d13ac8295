"""Streaming request bodies into a job's directory, with size limits and checked file names.

A multipart ``POST /v1/jobs`` has one ``shot`` part (the shot as JSON) and any number of asset
parts whose file names are the shot's relative asset paths (``meshes/flag.obj``). Parts are
written to disk as they arrive; nothing is held in memory but the shot document.
"""

from __future__ import annotations

import re
import shutil
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from python_multipart.multipart import MultipartParser, parse_options_header

SAFE_PART = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}$")


class UploadError(Exception):
    """A problem with the request body: status code, field and message."""

    def __init__(self, status: int, field: str | None, problem: str) -> None:
        super().__init__(problem)
        self.status = status
        self.field = field
        self.problem = problem


def normalize_asset_path(name: str) -> str:
    """'./meshes//a.obj' -> 'meshes/a.obj' (the form uploads are stored and compared in)."""
    return "/".join(p for p in name.replace("\\", "/").split("/") if p not in ("", "."))


def check_asset_name(name: str) -> str:
    """A relative path of safe components; anything else (``..``, absolute, odd characters) is refused."""
    parts = normalize_asset_path(name).split("/")
    if name.startswith(("/", "\\")) or len(name) > 256 or len(parts) > 8 or not all(SAFE_PART.match(p) for p in parts):
        raise UploadError(
            400, "assets", f"bad asset file name {name[:80]!r}: use a relative path of letters, digits, '_', '-' and '.'"
        )
    return "/".join(parts)


@dataclass
class ParsedUpload:
    shot_bytes: bytes | None = None
    assets: dict[str, int] = field(default_factory=dict)  # relative path -> size


async def read_limited(stream: AsyncIterator[bytes], limit: int) -> bytes:
    chunks: list[bytes] = []
    size = 0
    async for chunk in stream:
        size += len(chunk)
        if size > limit:
            raise UploadError(413, None, f"request body exceeds the limit of {limit} bytes")
        chunks.append(chunk)
    return b"".join(chunks)


async def receive_multipart(
    stream: AsyncIterator[bytes], content_type: str, assets_dir: Path, max_bytes: int, max_shot_bytes: int, max_files: int
) -> ParsedUpload:
    _, params = parse_options_header(content_type)
    boundary = params.get(b"boundary")
    if not boundary:
        raise UploadError(400, None, "multipart body without a boundary")
    result = ParsedUpload()
    state: dict[str, object] = {}
    headers: dict[bytes, bytes] = {}
    header_name = bytearray()
    header_value = bytearray()
    shot_buffer = bytearray()
    errors: list[UploadError] = []

    def fail(error: UploadError) -> None:
        if not errors:
            errors.append(error)

    def on_part_begin() -> None:
        headers.clear()
        state.clear()

    def on_header_field(data: bytes, start: int, end: int) -> None:
        header_name.extend(data[start:end])

    def on_header_value(data: bytes, start: int, end: int) -> None:
        header_value.extend(data[start:end])

    def on_header_end() -> None:
        headers[bytes(header_name).lower()] = bytes(header_value)
        header_name.clear()
        header_value.clear()

    def on_headers_finished() -> None:
        if errors:
            return
        _, disp = parse_options_header(headers.get(b"content-disposition", b""))
        name = disp.get(b"name", b"").decode("utf-8", "replace")
        filename = disp.get(b"filename")
        if name == "shot":
            if result.shot_bytes is not None or state.get("kind") == "shot":
                fail(UploadError(400, "shot", "more than one 'shot' part"))
                return
            state["kind"] = "shot"
            return
        if filename is None:
            fail(UploadError(400, name or None, f"unexpected form field {name!r}: send 'shot' and asset files"))
            return
        relative = check_asset_name(filename.decode("utf-8", "replace"))
        if relative in result.assets:
            fail(UploadError(400, "assets", f"asset {relative!r} uploaded twice"))
            return
        if len(result.assets) >= max_files:
            fail(UploadError(400, "assets", f"more than {max_files} asset files"))
            return
        target = assets_dir / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        state["kind"] = "asset"
        state["name"] = relative
        state["file"] = open(target, "wb")  # noqa: SIM115 - closed in on_part_end
        result.assets[relative] = 0

    def on_part_data(data: bytes, start: int, end: int) -> None:
        if errors:
            return
        kind = state.get("kind")
        if kind == "shot":
            shot_buffer.extend(data[start:end])
            if len(shot_buffer) > max_shot_bytes:
                fail(UploadError(413, "shot", f"the shot part exceeds {max_shot_bytes} bytes"))
        elif kind == "asset":
            f = state["file"]
            assert isinstance(f, IO) or hasattr(f, "write")
            f.write(data[start:end])  # type: ignore[union-attr]
            result.assets[str(state["name"])] += end - start

    def on_part_end() -> None:
        if state.get("kind") == "shot" and not errors:
            result.shot_bytes = bytes(shot_buffer)
        f = state.get("file")
        if f is not None:
            f.close()  # type: ignore[attr-defined]
        state.clear()

    parser = MultipartParser(
        boundary,
        callbacks={
            "on_part_begin": on_part_begin, "on_part_data": on_part_data, "on_part_end": on_part_end,
            "on_header_field": on_header_field, "on_header_value": on_header_value,
            "on_header_end": on_header_end, "on_headers_finished": on_headers_finished,
        },  # type: ignore[arg-type]
        max_header_count=16,
    )
    total = 0
    try:
        async for chunk in stream:
            total += len(chunk)
            if total > max_bytes:
                raise UploadError(413, None, f"upload exceeds the limit of {max_bytes} bytes")
            parser.write(chunk)
            if errors:
                raise errors[0]
        parser.finalize()
    except UploadError:
        raise
    except Exception as exc:  # python-multipart raises its own error types on malformed bodies
        raise UploadError(400, None, f"malformed multipart body: {exc}") from None
    finally:
        f = state.get("file")
        if f is not None:
            f.close()  # type: ignore[attr-defined]
    if errors:
        raise errors[0]
    if result.shot_bytes is None:
        raise UploadError(400, "shot", "the multipart body has no 'shot' part (the shot as JSON)")
    return result


# A job folder without a job record older than this is an upload the API never finished (it
# crashed or was killed mid-request): removed when an API process starts.
ORPHAN_AGE_SECONDS = 3600.0
JOB_FOLDER = re.compile(r"^[0-9a-f]{32}$")


async def remove_orphaned_uploads(jobs_dir: Path, has_record: Callable[[str], Awaitable[bool]], now: float) -> list[str]:
    """Job folders in `jobs_dir` that no job record names and that nothing touched for
    ORPHAN_AGE_SECONDS (younger ones may be uploads in flight in another API process)."""
    removed: list[str] = []
    if not jobs_dir.is_dir():
        return removed
    for folder in sorted(jobs_dir.iterdir()):
        if not folder.is_dir() or not JOB_FOLDER.match(folder.name):
            continue
        newest = max([folder.stat().st_mtime] + [p.stat().st_mtime for p in folder.rglob("*")])
        if now - newest < ORPHAN_AGE_SECONDS or await has_record(folder.name):
            continue
        shutil.rmtree(folder, ignore_errors=True)
        removed.append(folder.name)
    return removed
