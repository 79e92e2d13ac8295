"""Blender cloth as the peer of the contact benchmark: the same scene, frame count and threads.

`bench.contact` resolves a shot with weft (`weft.scene`), turns it into a job (`blender_job`:
plain arrays) and runs `python -m bench.blender_peer JOB OUT` in a subprocess, so every scene
gets a fresh `bpy` session (factory settings, empty scene) and bpy never shares a process with
weft's solver. bpy is optional (`pip install -e ".[peer]"`, bpy==5.0.1, Python 3.11); nothing
in weft or its tests imports it.

Mapping of a weft shot onto Blender's cloth (everything not listed is Blender's default:
quality 5 steps per frame, tension/compression 15, shear 5, bending 0.5, air damping 1,
collision quality 2, cloth friction 5, self friction 5, ...):

- cloth: one mesh object from the shot's initial vertices and faces (all pieces in one object),
  at the identity transform. Blender's rest shape is the starting mesh: a shot's `rest`
  (e.g. `kind: positions`, the articulated dress's 0.9 girth) is not carried over.
- vertex mass (`settings.mass`, one value per vertex in Blender): the cloth's total mass
  (density x rest area over all faces) divided by the vertex count. Blender's defaults are
  tuned for 0.3 kg a vertex; with real masses (4e-5 kg for the 4k drape) its other defaults
  (air damping 1, spring damping) hold the cloth back: in a free fall without bodies it reaches
  only ~0.15 m/s. Blender's cloth also counts time in frames (gravity x 0.001 per frame^2):
  at 24 fps even a 0.3 kg vertex without air falls at ~0.6 g. Both are Blender as configured
  here, reported as measured, not corrected; `--blender-mass default` keeps Blender's 0.3 kg
  (a cloth that falls and drapes, for timing contact rather than a hovering sheet).
- collision distance (`collision_settings.distance_min`) = weft thickness (the largest over
  pieces); self-collision (`use_self_collision`) on when weft has it for some piece, its
  distance (`self_distance_min`) = weft thickness too. Bodies' outer thickness
  (`collision.thickness_outer`) is set to Blender's minimum, 0.001 m, so contact happens at
  about the same distance as weft's (Blender adds the two).
- pins: vertices pinned in place form a vertex group used as the pin group
  (`vertex_group_mass`, weight 1: held exactly). Vertices pinned to a body: the cloth object is
  parented to that body (only one body may hold pins), so the pin goals follow the body.
- gravity: `scene.gravity` = the shot's gravity vector (weft is y-up; Blender takes the vector
  as given, so the scene keeps weft's axes). fps: `scene.render.fps` (integer fps only).
- bodies: one mesh object each, with a collision modifier (only bodies weft collides with).
  A body whose animation is rigid (every frame a rotation plus translation of its first frame,
  recovered by a least-squares fit, residual under 1e-6 m) is animated by keyframed object
  transforms (location and quaternion); otherwise (a merged character) by one shape key per
  frame whose value is keyed 1 at its frame and 0 at the neighbouring frames (linear
  interpolation: the vertices move linearly between frames, as weft interpolates keyframes).
- threads: `scene.render.threads_mode = 'FIXED'`, `scene.render.threads = N`.
- stepping: `scene.frame_set(f)` for f = first .. last, each timed (frame 1 builds the cloth:
  its time is the setup, excluded from s/frame); cloth positions read per frame from the
  evaluated object (`evaluated_get(depsgraph)`), transformed to world space.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

BPY_MISSING = (
    "Blender peer: the 'bpy' module is not installed (it is an optional peer). Install it with "
    "`.venv/bin/pip install bpy==5.0.1` (or `pip install -e \".[peer]\"`; needs Python 3.11)."
)


def blender_job(scene: Any, frames: int, threads: int, mass: str = "mapped") -> dict[str, np.ndarray | str]:
    """The arrays the Blender side needs from a resolved weft scene (`weft.scene.Scene`).
    mass: 'mapped' (density x area per vertex) or 'default' (Blender's 0.3 kg a vertex)."""
    from weft.solver_setup import collision_switches

    shot = scene.shot
    switches = collision_switches(scene)
    uv = scene.face_uv.reshape(-1, 3, 2)
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    areas = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    total_mass = float(np.sum(scene.face_material["density"] * areas))
    body_pins = sorted(set(scene.body_pin_bodies.tolist()))
    if len(body_pins) > 1:
        raise ValueError("Blender peer: cloth pinned to more than one body is not supported")
    meta = {
        "name": shot.name,
        "fps": shot.fps,
        "frames": frames,
        "threads": threads,
        "gravity": list(shot.environment.gravity),
        "vertex_mass": total_mass / scene.vertex_count if mass == "mapped" else None,
        "thickness": max(p.material.thickness for p in shot.cloth),
        "self_collision": any(switches["piece_self_collide"]),
        "collide": switches["enabled"] and any(switches["piece_collide"]),
        "pin_body": body_pins[0] if body_pins else -1,
        "bodies": [{"name": b.name, "collide": bool(spec.collide)} for b, spec in zip(scene.bodies, shot.bodies)],
        "rest": shot.cloth[0].rest.kind,
    }
    job: dict[str, Any] = {
        "meta": json.dumps(meta),
        "positions": scene.positions,
        "faces": scene.faces,
        "fixed_pins": scene.fixed_pins,
        "body_pins": scene.body_pin_vertices,
    }
    for b, body in enumerate(scene.bodies):
        job[f"body{b}_faces"] = body.faces
        job[f"body{b}_frames"] = np.asarray(body.frames[:frames])
    return job


def run_peer(scene: Any, frames: int, threads: int, mass: str = "mapped", timeout: float = 3600.0) -> dict[str, Any]:
    """Runs a scene's first `frames` frames in Blender in a subprocess. Returns positions
    (frames, N, 3) (index 0: the initial state), frame_seconds (frames 2..), setup_seconds and
    the Blender side's notes. Raises RuntimeError with Blender's output when it fails."""
    with tempfile.TemporaryDirectory(prefix="weft-blender-") as tmp:
        job, out = Path(tmp) / "job.npz", Path(tmp) / "out.npz"
        np.savez(job, **blender_job(scene, frames, threads, mass))
        proc = subprocess.run([sys.executable, "-m", "bench.blender_peer", str(job), str(out)],
                              capture_output=True, text=True, timeout=timeout)
        if proc.returncode != 0 or not out.exists():
            raise RuntimeError(f"Blender peer failed (exit {proc.returncode}):\n{proc.stdout[-2000:]}\n"
                               f"{proc.stderr[-4000:]}")
        with np.load(out, allow_pickle=False) as result:
            return {
                "positions": result["positions"],
                "frame_seconds": result["frame_seconds"],
                "setup_seconds": float(result["setup_seconds"]),
                "info": json.loads(str(result["info"])),
            }


# -- inside the Blender subprocess ---------------------------------------------------------------

def rigid_fit(reference: np.ndarray, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Rotation R and translation t with moved ~ reference @ R.T + t (Kabsch), and the largest
    residual distance."""
    ca, cb = reference.mean(axis=0), moved.mean(axis=0)
    u, _, vt = np.linalg.svd((reference - ca).T @ (moved - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    t = cb - ca @ r.T
    residual = float(np.max(np.linalg.norm(reference @ r.T + t - moved, axis=1)))
    return r, t, residual


def new_mesh_object(bpy: Any, name: str, vertices: np.ndarray, faces: np.ndarray) -> Any:
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices.tolist(), [], faces.tolist())
    mesh.validate(clean_customdata=False)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def animate_body(bpy: Any, obj: Any, frames: np.ndarray, first: int) -> str:
    """Keys a body's per-frame positions: object transforms when rigid, shape keys otherwise."""
    from mathutils import Matrix

    fits = [rigid_fit(frames[0], f) for f in frames]
    scale = max(float(np.ptp(frames[0], axis=0).max()), 1e-3)
    if all(residual < 1e-6 * max(scale, 1.0) for _, _, residual in fits):
        obj.rotation_mode = "QUATERNION"
        for k, (r, t, _) in enumerate(fits):
            m = np.eye(4)
            m[:3, :3], m[:3, 3] = r, t
            obj.matrix_world = Matrix(m.tolist())
            obj.keyframe_insert("location", frame=first + k)
            obj.keyframe_insert("rotation_quaternion", frame=first + k)
        return "transforms"
    obj.shape_key_add(name="basis", from_mix=False)
    for k, positions in enumerate(frames):
        block = obj.shape_key_add(name=f"frame{k}", from_mix=False)
        block.data.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).ravel())
        for j, value in ((k - 1, 0.0), (k, 1.0), (k + 1, 0.0)):
            if 0 <= j < len(frames):
                block.value = value
                block.keyframe_insert("value", frame=first + j)
        block.value = 0.0
    obj.data.shape_keys.use_relative = True
    return "shape keys"


def world_positions(obj: Any, depsgraph: Any) -> np.ndarray:
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    evaluated.to_mesh_clear()
    m = np.array(evaluated.matrix_world)
    return co.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]


def simulate(job: dict[str, np.ndarray]) -> dict[str, Any]:
    try:
        import bpy
    except ImportError:
        raise SystemExit(BPY_MISSING) from None

    meta = json.loads(str(job["meta"]))
    frames, first = int(meta["frames"]), 1
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.preferences.edit.keyframe_new_interpolation_type = "LINEAR"
    scene = bpy.context.scene
    scene.render.threads_mode = "FIXED"
    scene.render.threads = int(meta["threads"])
    scene.render.fps = int(round(meta["fps"]))
    scene.render.fps_base = scene.render.fps / meta["fps"]
    scene.frame_start, scene.frame_end = first, first + frames - 1
    scene.gravity = meta["gravity"]

    bodies, animation_kinds = [], []
    for b, body in enumerate(meta["bodies"]):
        body_frames = job[f"body{b}_frames"]
        obj = new_mesh_object(bpy, body["name"], body_frames[0], job[f"body{b}_faces"])
        animation_kinds.append(animate_body(bpy, obj, body_frames, first))
        if body["collide"] and meta["collide"]:
            obj.modifiers.new("Collision", "COLLISION")
            obj.collision.thickness_outer = 0.001
        bodies.append(obj)

    cloth = new_mesh_object(bpy, "cloth", job["positions"], job["faces"])
    pinned = job["fixed_pins"].tolist()
    if meta["pin_body"] >= 0:
        scene.frame_set(first)
        cloth.parent = bodies[meta["pin_body"]]
        cloth.matrix_parent_inverse = bodies[meta["pin_body"]].matrix_world.inverted()
        pinned += job["body_pins"].tolist()
    modifier = cloth.modifiers.new("Cloth", "CLOTH")
    settings = modifier.settings
    if meta["vertex_mass"] is not None:
        settings.mass = meta["vertex_mass"]
    if pinned:
        group = cloth.vertex_groups.new(name="pins")
        group.add(pinned, 1.0, "REPLACE")
        settings.vertex_group_mass = "pins"
    collision = modifier.collision_settings
    collision.use_collision = bool(meta["collide"])
    collision.distance_min = meta["thickness"]
    collision.use_self_collision = bool(meta["self_collision"])
    collision.self_distance_min = meta["thickness"]
    modifier.point_cache.frame_start, modifier.point_cache.frame_end = first, first + frames - 1

    positions = np.empty((frames, len(job["positions"]), 3))
    seconds = np.empty(frames)
    body_error = 0.0
    for k in range(frames):
        start = time.perf_counter()
        scene.frame_set(first + k)
        seconds[k] = time.perf_counter() - start
        depsgraph = bpy.context.evaluated_depsgraph_get()
        positions[k] = world_positions(cloth, depsgraph)
        if k == frames - 1:
            for b, obj in enumerate(bodies):
                moved = world_positions(obj, depsgraph)
                body_error = max(body_error, float(np.max(np.linalg.norm(moved - job[f"body{b}_frames"][k], axis=1))))
    info = {
        "blender": bpy.app.version_string,
        "threads": scene.render.threads,
        "rest": "starting mesh" + (f" (weft rest: {meta['rest']})" if meta["rest"] != "initial" else ""),
        "vertex_mass_kg": settings.mass,
        "distance_min_m": meta["thickness"],
        "self_collision": bool(meta["self_collision"]),
        "quality_steps": settings.quality,
        "body_animation": sorted(set(animation_kinds)),
        "body_error_last_frame_m": body_error,
        "initial_offset_m": float(np.max(np.linalg.norm(positions[0] - job["positions"], axis=1))),
    }
    return {"positions": positions, "frame_seconds": seconds[1:], "setup_seconds": float(seconds[0]),
            "info": json.dumps(info)}


def main(argv: list[str]) -> None:
    if len(argv) != 2:
        raise SystemExit("usage: python -m bench.blender_peer JOB.npz OUT.npz (run by bench.contact)")
    with np.load(argv[0], allow_pickle=False) as archive:
        job = {k: archive[k] for k in archive.files}
    np.savez(argv[1], **simulate(job))


if __name__ == "__main__":
    main(sys.argv[1:])
