"""Asset files of a shot: meshes and arrays, read safely.

Nothing here trusts an asset path: paths are resolved inside the shot's directory and may not
leave it, file types are checked by suffix, meshes are checked for size (MAX_VERTICES),
finiteness and index range. Problems are ShotErrors located by field path.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from api_schemas import ArrayAsset, MeshSource, Shot
from weft.shot import ShotError

MESH_SUFFIXES = {".obj", ".ply"}
ARRAY_SUFFIXES = {".npz", ".npy", ".h5", ".hdf5"}
MAX_VERTICES = 5_000_000


def _resolve_asset(base_dir: Path, relative: str, field_path: str, suffixes: set[str]) -> Path:
    base = base_dir.resolve()
    candidate = (base / relative).resolve()
    if not candidate.is_relative_to(base):
        raise ShotError(field_path, "asset path leaves the shot's directory")
    if candidate.suffix.lower() not in suffixes:
        raise ShotError(field_path, f"unsupported file type '{candidate.suffix}' (expected one of {sorted(suffixes)})")
    if not candidate.is_file():
        raise ShotError(field_path, f"file not found: {relative}")
    return candidate


def load_array(base_dir: Path, asset: ArrayAsset, field_path: str) -> np.ndarray:
    path = _resolve_asset(base_dir, asset.path, field_path + ".path", ARRAY_SUFFIXES)
    key = asset.key or "positions"
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            return np.asarray(np.load(path, allow_pickle=False), dtype=np.float64)
        if suffix == ".npz":
            with np.load(path, allow_pickle=False) as archive:
                if key not in archive:
                    raise ShotError(field_path + ".key", f"'{key}' not in {asset.path} (has {sorted(archive.files)})")
                return np.asarray(archive[key], dtype=np.float64)
        import h5py

        with h5py.File(path, "r") as f:
            if key not in f or not isinstance(f[key], h5py.Dataset):
                raise ShotError(field_path + ".key", f"no dataset '{key}' in {asset.path}")
            return np.asarray(f[key][()], dtype=np.float64)
    except ShotError:
        raise
    except (OSError, ValueError) as exc:
        raise ShotError(field_path, f"cannot read {asset.path}: {exc}") from None


def load_mesh(base_dir: Path, mesh: MeshSource, field_path: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) float64 and faces (F, 3) int64, checked for finiteness and index range."""
    if mesh.path is not None:
        path = _resolve_asset(base_dir, mesh.path, field_path + ".path", MESH_SUFFIXES)
        import trimesh

        try:
            # process=False and maintain_order=True keep the file's vertices as they are: merging
            # or splitting at UV seams would silently change the cloth's topology.
            loaded = trimesh.load(path, process=False, maintain_order=True, force="mesh")
        except Exception as exc:  # trimesh raises many types for malformed files
            raise ShotError(field_path + ".path", f"cannot read mesh {mesh.path}: {exc}") from None
        vertices = np.asarray(loaded.vertices, dtype=np.float64).reshape(-1, 3)
        faces = np.asarray(loaded.faces, dtype=np.int64).reshape(-1, 3)
        where = field_path
    else:
        vertices = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)
        faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
        where = field_path
    if len(vertices) == 0:
        raise ShotError(where + ".vertices", "mesh is empty (no vertices)")
    if len(faces) == 0:
        raise ShotError(where + ".faces", "mesh has no faces")
    if len(vertices) > MAX_VERTICES:
        raise ShotError(where + ".vertices", f"{len(vertices)} vertices exceeds the limit of {MAX_VERTICES}")
    check_finite(vertices, where + ".vertices")
    check_faces(faces, len(vertices), where + ".faces")
    return vertices, faces


def check_finite(array: np.ndarray, field_path: str) -> None:
    bad = ~np.isfinite(array)
    if bad.any():
        index = np.argwhere(bad)[0]
        value = array[tuple(index)]
        kind = "NaN" if np.isnan(value) else "infinite"
        location = "".join(f"[{i}]" for i in index[:-1]) if array.ndim > 1 else f"[{index[0]}]"
        raise ShotError(f"{field_path}{location}", f"coordinate is {kind}")


def check_faces(faces: np.ndarray, vertex_count: int, field_path: str) -> None:
    out_of_range = (faces < 0) | (faces >= vertex_count)
    if out_of_range.any():
        f, c = np.argwhere(out_of_range)[0]
        raise ShotError(
            f"{field_path}[{f}]",
            f"vertex index {faces[f, c]} out of range (mesh has {vertex_count} vertices)",
        )
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    if repeated.any():
        f = int(np.argmax(repeated))
        raise ShotError(f"{field_path}[{f}]", f"triangle repeats a vertex {faces[f].tolist()}")


def shot_hash(shot: Shot, base_dir: Path) -> str:
    """SHA-256 over the canonical shot and the bytes of every asset it references."""
    digest = hashlib.sha256(shot.model_dump_json().encode())
    for path in sorted(asset_paths(shot)):
        candidate = (base_dir / path).resolve()
        if candidate.is_file():
            digest.update(path.encode())
            digest.update(hashlib.sha256(candidate.read_bytes()).digest())
    return digest.hexdigest()


def asset_paths(shot: Shot) -> set[str]:
    paths: set[str] = set()
    for piece in shot.cloth:
        if piece.mesh.path:
            paths.add(piece.mesh.path)
        for value in (piece.rest.positions, piece.rest.face_uvs):
            if isinstance(value, ArrayAsset):
                paths.add(value.path)
    for body in shot.bodies:
        if body.mesh.path:
            paths.add(body.mesh.path)
        if body.animation is not None:
            paths.add(body.animation.path)
    return paths
