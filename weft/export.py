"""A weft cache as files other tools read: USD (Maya, Houdini, Blender, usdview) and a
Wavefront OBJ sequence. Only finished frames are exported, so a cache still being written (or
stopped early) exports what it has.

USD layout: ``/weft`` (the default prim, an Xform) holds one ``UsdGeomMesh`` per cloth piece
under ``/weft/cloth/<piece>``, each with its triangles (faceVertexCounts / faceVertexIndices),
``points`` time-sampled at every exported frame and, optionally, ``velocities`` (m/s; USD reads
them per second of stage time, and timeCodesPerSecond is the shot's fps, so they match the
frame spacing). Time code = frame number. Units: metres (``metersPerUnit = 1``). Up axis: Z
when the shot's gravity lies along Z, else Y (weft's default gravity is ``(0, -9.81, 0)``): up is
what gravity pulls against. The root layer's custom data records the weft version, the shot's
name and its hash. Kinematic bodies are exported under ``/weft/bodies/<name>`` when the cache
keeps their motion (the shot's ``outputs.body_motion``); otherwise the cache has their triangles
only.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from weft.cache import CACHE_FORMAT, CacheError, open_cache_reader


class ExportError(ValueError):
    """A cache that cannot be exported as asked; the message names the file and the problem."""


@dataclass(frozen=True)
class ExportSummary:
    """What an export wrote: the USD file or the OBJ folder, and which frames and pieces."""

    path: Path
    frames: tuple[int, int]  # first and last exported frame numbers
    frame_count: int
    pieces: tuple[str, ...]


@dataclass(frozen=True)
class _Piece:
    name: str
    vertex_offset: int
    vertex_count: int
    faces: np.ndarray  # local indices


@dataclass(frozen=True)
class _Cache:
    shot_name: str
    shot_hash: str
    weft_version: str
    fps: float
    gravity: tuple[float, float, float]
    frames: np.ndarray  # frame numbers of the rows to export
    rows: np.ndarray  # their row indices
    pieces: list[_Piece]


def _read(f: Any, path: Path, frames: range | None) -> _Cache:
    if f.attrs.get("format") != CACHE_FORMAT:
        raise ExportError(f"{path} is not a weft cache (no format attribute '{CACHE_FORMAT}')")
    numbers = np.asarray(f["frames/frame"][()])
    if len(numbers) == 0:
        raise ExportError(f"{path} has no finished frame yet")
    rows = np.arange(len(numbers)) if frames is None else _selected_rows(numbers, frames, path)
    shot = json.loads(f.attrs["shot_json"])
    gravity = tuple(float(g) for g in shot.get("environment", {}).get("gravity", (0.0, -9.81, 0.0)))
    pieces = [
        _Piece(name, int(g.attrs["vertex_offset"]), int(g.attrs["vertex_count"]), np.asarray(g["faces"][()]))
        for name, g in f["cloth/pieces"].items()
    ]
    pieces.sort(key=lambda p: p.vertex_offset)
    return _Cache(str(f.attrs["shot_name"]), str(f.attrs["shot_hash"]), str(f.attrs["weft_version"]),
                  float(f.attrs["fps"]), gravity, numbers[rows], rows, pieces)  # type: ignore[arg-type]


def _selected_rows(numbers: np.ndarray, frames: range, path: Path) -> np.ndarray:
    """Row indices of the selected frame numbers; every one must be a finished frame."""
    available = f"it has frames {int(numbers[0])}-{int(numbers[-1])}"
    if len(frames) == 0:
        raise ExportError(f"the frame selection {frames!r} is empty; {path}: {available}")
    first, last = sorted((frames[0], frames[-1]))
    if first < numbers[0] or last > numbers[-1]:  # checked before iterating: the range may be huge
        asked = f"frame {first} is" if first == last else f"frames {first}-{last} are"
        raise ExportError(f"{asked} not {'all ' if first != last else ''}in {path}: {available}")
    row_of = {int(n): row for row, n in enumerate(numbers)}
    missing = [n for n in frames if n not in row_of]
    if missing:
        raise ExportError(f"frame {missing[0]} is not in {path}: {available}")
    return np.array([row_of[n] for n in frames])


def _open(path: Path) -> Any:
    if not path.is_file():
        raise ExportError(f"no such file: {path}")
    if not h5py.is_hdf5(path):
        raise ExportError(f"{path} is not a weft cache (not an HDF5 file)")
    try:
        return open_cache_reader(path)
    except CacheError as exc:
        raise ExportError(str(exc)) from None


def up_axis(gravity: tuple[float, float, float]) -> str:
    """'Y' or 'Z': the axis gravity pulls against, when it lies along one of them."""
    g = np.abs(np.asarray(gravity))
    return "Z" if g.max() > 0 and int(np.argmax(g)) == 2 else "Y"


def _check_parent(out: Path) -> None:
    if not out.parent.is_dir():
        raise ExportError(f"cannot write {out}: folder {out.parent} does not exist")


def export_usd(cache_path: str | Path, out_path: str | Path, *, velocities: bool = True, bodies: bool = True,
               frames: range | None = None) -> ExportSummary:
    """Write the cache's cloth as a USD stage (.usd, .usda or .usdc), replacing `out_path` atomically.

    Up axis: Z when the shot's gravity lies along Z, else Y (weft's default gravity is -Y). The
    stage's up axis tells a DCC which way is up, and that is the direction gravity pulls against;
    USD has no -Y or -Z, so the axis alone is recorded. A layer of `out_path` already loaded in this
    process is reloaded, so a stage opened on the previous file sees the new one.
    """
    try:
        from pxr import Sdf, Tf, Usd, UsdGeom, Vt
    except ImportError:
        raise ExportError("USD export needs usd-core (a dependency of weft): pip install usd-core") from None
    cache_path, out = Path(cache_path), Path(out_path)
    if out.suffix.lower() not in (".usd", ".usda", ".usdc"):
        raise ExportError(f"{out}: a USD file name ends in .usd, .usda or .usdc")
    _check_parent(out)
    with _open(cache_path) as f:
        cache = _read(f, cache_path, frames)
        temporary = out.with_name(f".{out.stem}.{os.getpid()}.partial{out.suffix}")
        stage = Usd.Stage.CreateNew(str(temporary))
        try:
            UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if up_axis(cache.gravity) == "Z" else UsdGeom.Tokens.y)
            UsdGeom.SetStageMetersPerUnit(stage, 1.0)
            stage.SetTimeCodesPerSecond(cache.fps)
            stage.SetFramesPerSecond(cache.fps)
            stage.SetStartTimeCode(float(cache.frames[0]))
            stage.SetEndTimeCode(float(cache.frames[-1]))
            root = UsdGeom.Xform.Define(stage, "/weft")
            stage.SetDefaultPrim(root.GetPrim())
            stage.GetRootLayer().customLayerData = {
                "weft:version": cache.weft_version, "weft:shot": cache.shot_name, "weft:shot_hash": cache.shot_hash}
            UsdGeom.Scope.Define(stage, "/weft/cloth")
            meshes, used = [], set()
            for piece in cache.pieces:
                prim_name = Tf.MakeValidIdentifier(piece.name)
                while prim_name in used:  # two piece names that map to one identifier
                    prim_name += "_"
                used.add(prim_name)
                mesh = UsdGeom.Mesh.Define(stage, f"/weft/cloth/{prim_name}")
                mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(piece.faces)))
                mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(piece.faces.astype(np.int32).ravel().tolist()))
                mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
                mesh.CreateDoubleSidedAttr(True)
                mesh.GetPrim().SetCustomDataByKey("weft:piece", piece.name)
                meshes.append((piece, mesh, mesh.CreatePointsAttr(), mesh.CreateVelocitiesAttr() if velocities else None))
            positions, speeds = f["frames/positions"], f["frames/velocities"]
            for number, row in zip(cache.frames, cache.rows, strict=True):
                x = np.asarray(positions[int(row)])
                v = np.asarray(speeds[int(row)]) if velocities else None
                for piece, _, points, velocity in meshes:
                    part = slice(piece.vertex_offset, piece.vertex_offset + piece.vertex_count)
                    points.Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(x[part])), float(number))
                    if velocity is not None and v is not None:
                        velocity.Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(v[part])), float(number))
            if bodies:
                _write_bodies(stage, f, cache)
            stage.GetRootLayer().Save()
            del stage
            temporary.replace(out)
        finally:
            temporary.unlink(missing_ok=True)
    loaded = Sdf.Layer.Find(str(out))
    if loaded is not None:
        loaded.Reload(force=True)
    return ExportSummary(out, (int(cache.frames[0]), int(cache.frames[-1])), len(cache.frames),
                         tuple(p.name for p in cache.pieces))


def _write_bodies(stage: Any, f: Any, cache: _Cache) -> None:
    """The bodies whose motion the cache keeps (outputs.body_motion), under /weft/bodies/<name>,
    their points sampled at the exported frames."""
    from pxr import Tf, UsdGeom, Vt

    moving = {name: g for name, g in f["bodies"].items() if "positions" in g}
    if not moving:
        return
    UsdGeom.Scope.Define(stage, "/weft/bodies")
    used: set[str] = set()
    for name, group in moving.items():
        prim_name = Tf.MakeValidIdentifier(name)
        while prim_name in used:
            prim_name += "_"
        used.add(prim_name)
        mesh = UsdGeom.Mesh.Define(stage, f"/weft/bodies/{prim_name}")
        faces = np.asarray(group["faces"][()])
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(faces)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(faces.astype(np.int32).ravel().tolist()))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.GetPrim().SetCustomDataByKey("weft:body", name)
        points = mesh.CreatePointsAttr()
        for number, row in zip(cache.frames, cache.rows, strict=True):
            points.Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(group["positions"][int(row)])), float(number))


def _write_atomically(target: Path, lines: list[str]) -> None:
    """Write `lines` to a hidden temporary file beside `target`, then rename it to `target`."""
    with tempfile.NamedTemporaryFile("w", dir=target.parent, prefix=f".{target.stem}.", suffix=".partial",
                                     delete=False) as tmp:
        temporary = Path(tmp.name)
        try:
            tmp.writelines(lines)
        except BaseException:
            tmp.close()
            temporary.unlink(missing_ok=True)
            raise
    temporary.replace(target)


def export_obj_sequence(cache_path: str | Path, out_dir: str | Path, *, frames: range | None = None) -> ExportSummary:
    """One OBJ per frame, ``<shot>_<frame:04d>.obj`` (all pieces, one group each), written
    atomically."""
    cache_path, out = Path(cache_path), Path(out_dir)
    _check_parent(out)
    if out.exists() and not out.is_dir():
        raise ExportError(f"cannot write the OBJ sequence into {out}: it is a file, not a folder")
    out.mkdir(exist_ok=True)
    with _open(cache_path) as f:
        cache = _read(f, cache_path, frames)
        positions = f["frames/positions"]
        for number, row in zip(cache.frames, cache.rows, strict=True):
            x = np.asarray(positions[int(row)], dtype=np.float64)
            lines = [f"# weft {cache.weft_version}: shot {cache.shot_name}, frame {int(number)}, metres\n"]
            lines += [f"v {p[0]:.7g} {p[1]:.7g} {p[2]:.7g}\n" for p in x]
            for piece in cache.pieces:
                lines.append(f"g {piece.name}\n")
                lines += [f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in piece.faces + piece.vertex_offset]
            target = out / f"{cache.shot_name}_{int(number):04d}.obj"
            _write_atomically(target, lines)
    return ExportSummary(out, (int(cache.frames[0]), int(cache.frames[-1])), len(cache.frames),
                         tuple(p.name for p in cache.pieces))
