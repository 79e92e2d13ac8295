"""Asset files of a shot: meshes and arrays, read safely.

Nothing here trusts an asset path: paths are resolved inside the shot's directory and may not
leave it, file types are checked by suffix, meshes are checked for size (MAX_VERTICES),
finiteness and index range. Array assets are checked by their declared shape and type before
they are read or decompressed (MAX_ARRAY_VALUES), and an HDF5 asset is read only through hard
links and from its own storage: external links, soft links, external raw storage and virtual
datasets are refused unread (they could reach any file the server can read). Problems are
ShotErrors located by field path (422 in the service).
"""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from api_schemas import ArrayAsset, MeshSource, Shot
from weft.shot import ShotError

MESH_SUFFIXES = {".obj", ".ply"}
ARRAY_SUFFIXES = {".npz", ".npy", ".h5", ".hdf5"}
MAX_VERTICES = 5_000_000
# Values an array asset may declare (2 GiB as float64): checked before reading or decompressing.
MAX_ARRAY_VALUES = 268_435_456


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


def _checked_header(shape: tuple[int, ...], dtype: np.dtype, where: str, what: str) -> None:
    """Refuse an array by its declared shape and type, before anything is read or decompressed."""
    if dtype.hasobject or dtype.kind not in "biuf":
        raise ShotError(where, f"{what} holds {dtype} values; expected numbers")
    count = 1
    for n in shape:
        count *= int(n)
    if count > MAX_ARRAY_VALUES:
        raise ShotError(where, f"{what} declares shape {tuple(shape)} ({count} values), over the limit of "
                               f"{MAX_ARRAY_VALUES}")


def _npy_header(stream: Any, where: str, what: str) -> None:
    try:
        version = np.lib.format.read_magic(stream)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(stream)
        else:
            shape, _, dtype = np.lib.format.read_array_header_2_0(stream)
    except (ValueError, OSError, EOFError) as exc:
        raise ShotError(where, f"{what} is not a valid .npy array: {exc}") from None
    _checked_header(shape, dtype, where, what)


def _hdf5_dataset(f: Any, key: str, where: str, name: str) -> Any:
    """The dataset at `key`, reached through hard links only and stored in the file itself:
    external and soft links, external raw storage and virtual datasets are refused before they
    are followed (they could read any file the server can), with the same answer whether or not
    their target exists."""
    import h5py

    node = f
    parts = [p for p in key.split("/") if p]
    if not parts:
        raise ShotError(where + ".key", f"no dataset '{key}' in {name}")
    for depth, part in enumerate(parts):
        if not isinstance(node, h5py.Group) or part not in node:
            raise ShotError(where + ".key", f"no dataset '{key}' in {name}")
        link = node.get(part, getlink=True)
        if not isinstance(link, h5py.HardLink):
            kind = "an external link" if isinstance(link, h5py.ExternalLink) else "a soft link"
            raise ShotError(where + ".key", f"'{'/'.join(parts[:depth + 1])}' in {name} is {kind}: refused "
                                            "(an asset must hold its data itself)")
        node = node[part]
    if not isinstance(node, h5py.Dataset):
        raise ShotError(where + ".key", f"no dataset '{key}' in {name}")
    if node.is_virtual or node.external:
        raise ShotError(where + ".key", f"dataset '{key}' in {name} is stored outside the file: refused "
                                        "(an asset must hold its data itself)")
    _checked_header(node.shape or (), node.dtype, where, f"dataset '{key}' in {name}")
    return node


def load_array(base_dir: Path, asset: ArrayAsset, field_path: str) -> np.ndarray:
    """A numeric array from .npy, .npz (member `key`) or HDF5 (dataset `key`), its declared shape
    and type checked against MAX_ARRAY_VALUES before it is read or decompressed."""
    path = _resolve_asset(base_dir, asset.path, field_path + ".path", ARRAY_SUFFIXES)
    key = asset.key or "positions"
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            with open(path, "rb") as stream:
                _npy_header(stream, field_path, asset.path)
            return np.asarray(np.load(path, allow_pickle=False), dtype=np.float64)
        if suffix == ".npz":
            with zipfile.ZipFile(path) as archive:
                members = {n[:-4]: n for n in archive.namelist() if n.endswith(".npy")}
                if key not in members:
                    raise ShotError(field_path + ".key", f"'{key}' not in {asset.path} (has {sorted(members)})")
                info = archive.getinfo(members[key])
                if info.file_size > 8 * MAX_ARRAY_VALUES + 65536:
                    raise ShotError(field_path, f"'{key}' in {asset.path} unpacks to {info.file_size} bytes, over "
                                                f"the limit of {8 * MAX_ARRAY_VALUES + 65536}")
                with archive.open(info) as stream:
                    _npy_header(stream, field_path, f"'{key}' in {asset.path}")
                with archive.open(info) as stream:
                    return np.asarray(np.lib.format.read_array(stream, allow_pickle=False), dtype=np.float64)
        import h5py

        with h5py.File(path, "r") as f:
            return np.asarray(_hdf5_dataset(f, key, field_path, asset.path)[()], dtype=np.float64)
    except ShotError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zipfile.LargeZipFile, KeyError) as exc:
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


def load_obj_corner_uvs(base_dir: Path, mesh: MeshSource, faces: np.ndarray, field_path: str) -> np.ndarray:
    """The (u, v) of each triangle corner from an OBJ file's ``vt`` records and its faces'
    ``v/vt`` indices, shape (F, 3, 2), in the file's units. The faces must be the file's own
    triangles in order (checked against ``faces``, the mesh as loaded), each corner with a vt."""
    if mesh.path is None or Path(mesh.path).suffix.lower() != ".obj":
        raise ShotError(field_path, "a 'uv' rest shape without face_uvs reads the mesh's OBJ vt coordinates: "
                                    "the mesh must be an .obj file (or give face_uvs)")
    path = _resolve_asset(base_dir, mesh.path, field_path, MESH_SUFFIXES)
    texture: list[tuple[float, float]] = []
    corners: list[list[int]] = []
    positions: list[list[int]] = []
    with open(path, encoding="utf-8", errors="replace") as obj:
        for number, line in enumerate(obj, 1):
            fields = line.split()
            if not fields:
                continue
            if fields[0] == "vt":
                try:
                    texture.append((float(fields[1]), float(fields[2])))
                except (IndexError, ValueError):
                    raise ShotError(field_path, f"{mesh.path} line {number}: a vt record needs two numbers") from None
            elif fields[0] == "f":
                if len(fields) != 4:
                    raise ShotError(field_path, f"{mesh.path} line {number}: a face with {len(fields) - 1} corners; "
                                                "the vt rest shape needs a triangulated OBJ")
                refs = [corner.split("/") for corner in fields[1:]]
                if any(len(r) < 2 or not r[1] for r in refs):
                    raise ShotError(field_path, f"{mesh.path} line {number}: a face corner without a vt index")
                try:
                    positions.append([int(r[0]) for r in refs])
                    corners.append([int(r[1]) for r in refs])
                except ValueError:
                    raise ShotError(field_path, f"{mesh.path} line {number}: malformed face indices") from None
    if not texture:
        raise ShotError(field_path, f"{mesh.path} has no vt records to take the rest shape from")
    def absolute(index: np.ndarray, count: int) -> np.ndarray:  # OBJ: 1-based, negative from the end
        return np.where(index < 0, count + index, index - 1)
    vt = absolute(np.asarray(corners, dtype=np.int64), len(texture))
    if vt.min() < 0 or vt.max() >= len(texture):
        raise ShotError(field_path, f"{mesh.path}: a face refers to a vt that does not exist ({len(texture)} vt)")
    v = np.asarray(positions, dtype=np.int64)
    if v.shape != faces.shape or not np.array_equal(absolute(v, int(faces.max()) + 1), faces):
        raise ShotError(field_path, f"{mesh.path}: its faces do not match the mesh as loaded")
    return np.asarray(texture, dtype=np.float64)[vt]


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
