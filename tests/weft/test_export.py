"""weft.export and `weft export`: a cache as USD (read back with pxr) and as an OBJ sequence."""

from __future__ import annotations

import copy
import subprocess
import sys
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
from pxr import Usd, UsdGeom

from scenes.builders import sheet_shot
from weft.cache import CacheWriter
from weft.export import ExportError, export_obj_sequence, export_usd, up_axis
from weft.runner import ShotRunner
from weft.shot import parse_shot
from weft.solver_setup import resolve_scene

WEFT = str(Path(sys.executable).with_name("weft"))


def two_piece_shot(gravity: tuple[float, float, float] = (0.0, -9.81, 0.0)) -> dict[str, Any]:
    shot = sheet_shot("export", 5, 4, 0.4, 0.3, plane="xz", pins=[0, 4], frames=4, gravity=gravity)
    second = copy.deepcopy(shot["cloth"][0])
    second["name"] = "skirt.back"
    second["mesh"]["vertices"] = [[x, y - 0.2, z + 0.5] for x, y, z in second["mesh"]["vertices"]]
    shot["cloth"].append(second)
    shot["features"] = {"self_collision": False}
    return shot


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("export") / "cache.h5"
    ShotRunner(resolve_scene(parse_shot(two_piece_shot()), path.parent), path).run()
    return path


def test_usd_holds_every_frame_of_every_piece_exactly(cache: Path, tmp_path: Path) -> None:
    summary = export_usd(cache, tmp_path / "shot.usd")
    assert summary.frames == (1, 4) and summary.frame_count == 4 and summary.pieces == ("sheet", "skirt.back")
    stage = Usd.Stage.Open(str(tmp_path / "shot.usd"))
    assert stage.GetTimeCodesPerSecond() == 24.0 and stage.GetFramesPerSecond() == 24.0
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (1.0, 4.0)
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetPath() == "/weft"
    with h5py.File(cache, "r") as f:
        recorded = {"weft:version": f.attrs["weft_version"], "weft:shot": "export",
                    "weft:shot_hash": f.attrs["shot_hash"]}
    assert dict(stage.GetRootLayer().customLayerData) == recorded and len(recorded["weft:shot_hash"]) == 64
    with h5py.File(cache, "r") as f:
        positions, velocities = f["frames/positions"][()], f["frames/velocities"][()]
        pieces = {name: (int(g.attrs["vertex_offset"]), int(g.attrs["vertex_count"]), g["faces"][()])
                  for name, g in f["cloth/pieces"].items()}
    for name, prim_name in (("sheet", "sheet"), ("skirt.back", "skirt_back")):
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"/weft/cloth/{prim_name}"))
        offset, count, faces = pieces[name]
        assert mesh.GetPrim().GetCustomDataByKey("weft:piece") == name
        assert list(mesh.GetFaceVertexCountsAttr().Get()) == [3] * len(faces)
        assert list(mesh.GetFaceVertexIndicesAttr().Get()) == faces.ravel().tolist()
        assert mesh.GetPointsAttr().GetTimeSamples() == [1.0, 2.0, 3.0, 4.0]
        for row, frame in enumerate((1.0, 2.0, 3.0, 4.0)):
            points = np.array(mesh.GetPointsAttr().Get(frame), dtype=np.float32)
            assert np.array_equal(points, positions[row, offset : offset + count])
            speeds = np.array(mesh.GetVelocitiesAttr().Get(frame), dtype=np.float32)
            assert np.array_equal(speeds, velocities[row, offset : offset + count])
    assert not np.array_equal(positions[0], positions[-1])  # the cloth moved: the samples differ


def test_usd_frame_selection_and_no_velocities(cache: Path, tmp_path: Path) -> None:
    summary = export_usd(cache, tmp_path / "part.usda", velocities=False, frames=range(2, 4))
    assert summary.frames == (2, 3)
    stage = Usd.Stage.Open(str(tmp_path / "part.usda"))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/weft/cloth/sheet"))
    assert mesh.GetPointsAttr().GetTimeSamples() == [2.0, 3.0] and not mesh.GetVelocitiesAttr().HasValue()


def test_up_axis_follows_gravity() -> None:
    assert up_axis((0.0, -9.81, 0.0)) == "Y" and up_axis((0.0, 0.0, -9.81)) == "Z" and up_axis((0.0, 0.0, 0.0)) == "Y"


def test_obj_sequence_matches_the_cache(cache: Path, tmp_path: Path) -> None:
    summary = export_obj_sequence(cache, tmp_path / "objs")
    files = sorted((tmp_path / "objs").glob("*.obj"))
    assert [f.name for f in files] == [f"export_{n:04d}.obj" for n in (1, 2, 3, 4)] and summary.frame_count == 4
    assert not list((tmp_path / "objs").glob(".*"))  # no partial files left
    with h5py.File(cache, "r") as f:
        positions, faces = f["frames/positions"][()], f["cloth/faces"][()]
    for row, path in enumerate(files):
        lines = path.read_text().splitlines()
        vertices = np.array([[float(v) for v in line.split()[1:]] for line in lines if line.startswith("v ")])
        triangles = np.array([[int(v) - 1 for v in line.split()[1:]] for line in lines if line.startswith("f ")])
        assert np.allclose(vertices, positions[row], rtol=0, atol=1e-6)
        assert np.array_equal(triangles, faces)
        assert [line for line in lines if line.startswith("g ")] == ["g sheet", "g skirt.back"]


def test_bad_exports_name_the_problem(cache: Path, tmp_path: Path) -> None:
    not_a_cache = tmp_path / "other.h5"
    with h5py.File(not_a_cache, "w") as f:
        f["x"] = 1
    with pytest.raises(ExportError, match="is not a weft cache"):
        export_usd(not_a_cache, tmp_path / "a.usd")
    with pytest.raises(ExportError, match="frames 2-9 are not all in .*: it has frames 1-4"):
        export_usd(cache, tmp_path / "a.usd", frames=range(2, 10))
    with pytest.raises(ExportError, match="frame 9 is not in .*: it has frames 1-4"):
        export_obj_sequence(cache, tmp_path / "objs", frames=range(9, 10))
    with pytest.raises(ExportError, match=r"frame selection range\(3, 3\) is empty; .*cache.h5: it has frames 1-4"):
        export_usd(cache, tmp_path / "a.usd", frames=range(3, 3))
    text = tmp_path / "notes.h5"
    text.write_text("not hdf5")
    with pytest.raises(ExportError, match="notes.h5 is not a weft cache \\(not an HDF5 file\\)"):
        export_obj_sequence(text, tmp_path / "objs")
    with pytest.raises(ExportError, match="folder .*missing does not exist"):
        export_obj_sequence(cache, tmp_path / "missing" / "objs")
    with pytest.raises(ExportError, match="ends in .usd"):
        export_usd(cache, tmp_path / "a.abc")
    with pytest.raises(ExportError, match="no such file"):
        export_usd(tmp_path / "nope.h5", tmp_path / "a.usd")


def test_cli_export(cache: Path, tmp_path: Path) -> None:
    done = subprocess.run([WEFT, "export", str(cache), "--usd", str(tmp_path / "cli.usdc"), "--frames", "1:2"],
                          check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "frames 1-2 (2)" in done.stdout and (tmp_path / "cli.usdc").is_file()
    objs = subprocess.run([WEFT, "export", str(cache), "--obj-sequence", str(tmp_path / "seq")],
                          check=False, capture_output=True, text=True, timeout=120)
    assert objs.returncode == 0 and len(list((tmp_path / "seq").glob("*.obj"))) == 4
    for args, message in ((["--usd", "x.usd", "--obj-sequence", "d"], "give one of"),
                          (["--usd", str(tmp_path / "x.usd"), "--frames", "3-1"], "expected FIRST:LAST"),
                          (["--usd", str(tmp_path / "x.usd"), "--frames", "0:2"], "frames 0-2 are not all in"),
                          (["--obj-sequence", str(tmp_path / "no" / "seq")], "does not exist")):
        bad = subprocess.run([WEFT, "export", str(cache), *args],
                             check=False, capture_output=True, text=True, timeout=120)
        assert bad.returncode == 2 and message in bad.stderr, (args, bad.stderr)


def test_cli_without_usd_core_says_how_to_install_it(cache: Path, tmp_path: Path) -> None:
    # pxr cannot be imported in this interpreter (None in sys.modules makes the import fail)
    command = ("import sys; sys.modules['pxr'] = None; from weft.cli import app; "
               "sys.argv = ['weft', 'export', *sys.argv[1:]]; app()")
    usd = subprocess.run([sys.executable, "-c", command, str(cache), "--usd", str(tmp_path / "x.usd")],
                         check=False, capture_output=True, text=True, timeout=120)
    assert usd.returncode == 2 and "pip install usd-core" in usd.stderr, usd.stderr
    assert not (tmp_path / "x.usd").exists()
    objs = subprocess.run([sys.executable, "-c", command, str(cache), "--obj-sequence", str(tmp_path / "seq")],
                          check=False, capture_output=True, text=True, timeout=120)
    assert objs.returncode == 0 and len(list((tmp_path / "seq").glob("*.obj"))) == 4, objs.stderr


def test_stepped_selection_and_a_reexport_seen_by_an_open_stage(cache: Path, tmp_path: Path) -> None:
    out = tmp_path / "shot.usda"
    export_usd(cache, out, frames=range(1, 5, 2))
    stage = Usd.Stage.Open(str(out))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/weft/cloth/sheet"))
    assert mesh.GetPointsAttr().GetTimeSamples() == [1.0, 3.0]
    with h5py.File(cache, "r") as f:
        third = f["frames/positions"][2, : int(f["cloth/pieces/sheet"].attrs["vertex_count"])]
    assert np.array_equal(np.array(mesh.GetPointsAttr().Get(3.0), dtype=np.float32), third)
    export_usd(cache, out, frames=range(2, 4))  # replaces the file this process holds open
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (2.0, 3.0)
    assert mesh.GetPointsAttr().GetTimeSamples() == [2.0, 3.0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["shot.usda"]  # no temporary left


def test_a_running_and_a_partial_cache_export_their_finished_frames(tmp_path: Path) -> None:
    path = tmp_path / "z_up.h5"
    scene = resolve_scene(parse_shot(two_piece_shot(gravity=(0.0, 0.0, -9.81))), tmp_path)  # 4 frames planned
    live: list[Any] = []

    def export_while_running(record: Any) -> None:
        if record.index == 1:  # frames 1 and 2 written, the writer still holds the file
            live.append(export_usd(path, tmp_path / "live.usd"))
            live.append(export_obj_sequence(path, tmp_path / "live_objs"))

    ShotRunner(scene, path, frames=3).run(on_frame=export_while_running)
    assert [(s.frames, s.frame_count) for s in live] == [((1, 2), 2), ((1, 2), 2)]
    assert sorted(f.name for f in (tmp_path / "live_objs").iterdir()) == ["export_0001.obj", "export_0002.obj"]
    stage = Usd.Stage.Open(str(tmp_path / "live.usd"))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z and stage.GetEndTimeCode() == 2.0
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "partial" and list(f["frames/frame"][()]) == [1, 2, 3]
        positions = f["frames/positions"][()]
    sheet = UsdGeom.Mesh(stage.GetPrimAtPath("/weft/cloth/sheet")).GetPointsAttr()
    assert np.array_equal(np.array(sheet.Get(2.0), dtype=np.float32), positions[1, :20])
    assert export_usd(path, tmp_path / "partial.usd").frames == (1, 3)


def test_a_cache_without_finished_frames_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "empty.h5"
    scene = resolve_scene(parse_shot(two_piece_shot()), tmp_path)
    CacheWriter.create(path, scene, "test", 1).close("cancelled")
    with pytest.raises(ExportError, match="empty.h5 has no finished frame yet"):
        export_usd(path, tmp_path / "a.usd")
    assert not (tmp_path / "a.usd").exists()


def test_body_motion_is_kept_and_exported_when_the_shot_asks(tmp_path: Path) -> None:
    """outputs.body_motion: bodies/<name>/positions per frame in the cache (also through a
    resume), and /weft/bodies/<name> in the USD; without it, no body motion and no body prims."""
    from scenes.collision import box_mesh
    from scenes.builders import inline_mesh

    shot = two_piece_shot()
    vertices, faces = box_mesh((0.2, 0.2, 0.2), (0.0, -0.5, 0.0))
    np.save(tmp_path / "box.npy", vertices[None] + np.arange(4)[:, None, None] * np.array([0.01, 0.0, 0.0]))
    shot["bodies"] = [{"name": "prop.box", "mesh": inline_mesh(vertices, faces), "animation": {"path": "box.npy"}}]
    shot["outputs"] = {"body_motion": True}
    scene = resolve_scene(parse_shot(shot), tmp_path)
    ShotRunner(scene, tmp_path / "half.h5", frames=2).run()
    ShotRunner(scene, tmp_path / "half.h5", resume=True).run()  # the rewrite keeps the finished body rows
    with h5py.File(tmp_path / "half.h5", "r") as f:
        motion = f["bodies/prop.box/positions"][()]
    assert motion.shape == (4, len(vertices), 3)
    assert np.array_equal(motion, np.load(tmp_path / "box.npy").astype(np.float32))
    export_usd(tmp_path / "half.h5", tmp_path / "with.usda")
    stage = Usd.Stage.Open(str(tmp_path / "with.usda"))
    body = UsdGeom.Mesh(stage.GetPrimAtPath("/weft/bodies/prop_box"))
    assert body.GetPrim().GetCustomDataByKey("weft:body") == "prop.box"
    assert np.array_equal(np.array(body.GetPointsAttr().Get(3.0), dtype=np.float32), motion[2])
    export_usd(tmp_path / "half.h5", tmp_path / "without.usda", bodies=False)
    assert not Usd.Stage.Open(str(tmp_path / "without.usda")).GetPrimAtPath("/weft/bodies")

    shot["outputs"] = {"body_motion": False}
    plain = resolve_scene(parse_shot(shot), tmp_path)
    ShotRunner(plain, tmp_path / "plain.h5").run()
    with h5py.File(tmp_path / "plain.h5", "r") as f:
        assert "positions" not in f["bodies/prop.box"]
    export_usd(tmp_path / "plain.h5", tmp_path / "plain.usda")
    assert not Usd.Stage.Open(str(tmp_path / "plain.usda")).GetPrimAtPath("/weft/bodies")
