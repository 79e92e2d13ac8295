"""Asset files as an attacker writes them (issue 15): each test repeats one attack on
`weft.assets.load_array` and asserts a ShotError naming the field, never a read of another
file, a crash or a huge allocation."""

from __future__ import annotations

import io
import struct
import zipfile
from pathlib import Path

import h5py
import numpy as np
import pytest

from api_schemas import ArrayAsset
from weft.assets import MAX_ARRAY_VALUES, load_array
from weft.shot import ShotError

FIELD = "bodies[0].animation"


def load(directory: Path, name: str, key: str | None = None) -> np.ndarray:
    return load_array(directory, ArrayAsset(path=name, key=key), FIELD)


def refused(directory: Path, name: str, key: str | None = None) -> ShotError:
    with pytest.raises(ShotError) as caught:
        load(directory, name, key)
    assert caught.value.field.startswith(FIELD)
    return caught.value


def test_hdf5_dataset_stored_externally_in_etc_passwd_is_refused_unread(tmp_path: Path) -> None:
    size = Path("/etc/passwd").stat().st_size // 8 * 8
    with h5py.File(tmp_path / "anim.h5", "w") as f:
        f.create_dataset("positions", shape=(size // 8,), dtype="<f8", external=[("/etc/passwd", 0, size)])
    error = refused(tmp_path, "anim.h5")
    assert "stored outside the file" in str(error) and "root" not in str(error)


def test_hdf5_external_link_into_another_cache_is_refused_without_revealing_it(tmp_path: Path) -> None:
    other = tmp_path / "secret"
    other.mkdir()
    with h5py.File(other / "cache.h5", "w") as f:
        f.create_dataset("frames/positions", data=np.zeros((3, 777, 3)))
    with h5py.File(tmp_path / "anim.h5", "w") as f:
        f["positions"] = h5py.ExternalLink(str(other / "cache.h5"), "frames/positions")
    error = refused(tmp_path, "anim.h5")
    assert "external link" in str(error) and "777" not in str(error)


def test_external_link_to_a_missing_file_answers_the_same_no_existence_oracle(tmp_path: Path) -> None:
    with h5py.File(tmp_path / "a.h5", "w") as f:
        f["positions"] = h5py.ExternalLink("/no/such/file.h5", "x")
    with h5py.File(tmp_path / "b.h5", "w") as f:
        f["positions"] = h5py.ExternalLink("/etc/hostname", "x")
    assert str(refused(tmp_path, "a.h5")).replace("a.h5", "") == str(refused(tmp_path, "b.h5")).replace("b.h5", "")


def test_hdf5_group_reached_through_an_external_link_is_refused(tmp_path: Path) -> None:
    with h5py.File(tmp_path / "anim.h5", "w") as f:
        f["outside"] = h5py.ExternalLink("/etc/hostname", "/")
    assert "external link" in str(refused(tmp_path, "anim.h5", key="outside/positions"))


def test_hdf5_fill_value_only_dataset_over_the_limit_is_refused_before_reading(tmp_path: Path) -> None:
    with h5py.File(tmp_path / "anim.h5", "w") as f:
        f.create_dataset("positions", shape=(MAX_ARRAY_VALUES // 3 + 1, 3), dtype="<f8", chunks=(1024, 3))
    assert "over the limit" in str(refused(tmp_path, "anim.h5"))


def test_corrupt_npz_is_a_field_error_not_a_500(tmp_path: Path) -> None:
    (tmp_path / "anim.npz").write_bytes(b"PK\x03\x04 this is not really a zip archive")
    assert "cannot read anim.npz" in str(refused(tmp_path, "anim.npz"))


def test_npy_whose_header_claims_a_huge_shape_is_refused_before_allocating(tmp_path: Path) -> None:
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (100000000000, 3), }"
    header += " " * (63 - len(header) % 64) + "\n"
    (tmp_path / "anim.npy").write_bytes(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode())
    assert "over the limit" in str(refused(tmp_path, "anim.npy"))


def test_small_npz_that_unpacks_to_gigabytes_is_refused_before_decompressing(tmp_path: Path) -> None:
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": "<f8", "fortran_order": False,
                                                   "shape": (MAX_ARRAY_VALUES, 2)})
    with zipfile.ZipFile(tmp_path / "anim.npz", "w", compression=zipfile.ZIP_DEFLATED) as archive:
        with archive.open("positions.npy", "w", force_zip64=True) as member:
            member.write(buffer.getvalue())
            zeros = bytes(1 << 20)
            for _ in range(64):  # 64 MiB of zeros: a few hundred KiB compressed
                member.write(zeros)
    assert (tmp_path / "anim.npz").stat().st_size < 1_000_000
    assert "over the limit" in str(refused(tmp_path, "anim.npz"))


def test_object_arrays_are_refused(tmp_path: Path) -> None:
    np.save(tmp_path / "anim.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    assert "expected numbers" in str(refused(tmp_path, "anim.npy"))


def test_plain_assets_still_load(tmp_path: Path) -> None:
    data = np.arange(24, dtype=np.float32).reshape(2, 4, 3)
    np.save(tmp_path / "a.npy", data)
    np.savez_compressed(tmp_path / "a.npz", positions=data)
    with h5py.File(tmp_path / "a.h5", "w") as f:
        f.create_dataset("group/positions", data=data)
    for name, key in (("a.npy", None), ("a.npz", None), ("a.h5", "group/positions")):
        assert np.array_equal(load(tmp_path, name, key), data)


def test_malformed_obj_names_the_field_not_a_missing_module(tmp_path: Path) -> None:
    from api_schemas import MeshSource
    from weft.assets import load_mesh

    (tmp_path / "cloth.obj").write_bytes(b"v 0 0 0\nv \xff\xfe 1 0\nf 1 2 3 4 5\n\x00\x00garbage\n")
    with pytest.raises(ShotError) as caught:
        load_mesh(tmp_path, MeshSource(path="cloth.obj"), "cloth[0].mesh")
    assert caught.value.field.startswith("cloth[0].mesh") and "No module named" not in str(caught.value)
