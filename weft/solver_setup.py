"""Turn a validated Shot plus its asset files into flat arrays and the C++ solver's setup.

``resolve_scene`` loads and checks every asset (``weft.assets``) and concatenates the cloth pieces
into a Scene; ``build_setup`` turns a Scene into the solver's SimulationSetup; the collision
switches (``collision_switches``: "model only what a scene needs") decide which features the
solver runs. Problems are ShotErrors located by field path.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from api_schemas import ArrayAsset, Shot
from weft.assets import check_finite, load_array, load_mesh, load_obj_corner_uvs, shot_hash
from weft.body_shells import SolverBody, shell_of_nearest_point, split_bodies
from weft.pin_room import PinGroup, check_pin_room
from weft.shot import ShotError


@dataclass
class BodyArrays:
    name: str
    faces: np.ndarray  # (F, 3) int32
    frames: np.ndarray  # (frame_count, V, 3) float64


@dataclass
class PieceArrays:
    name: str
    vertex_offset: int
    vertex_count: int
    face_offset: int
    faces: np.ndarray  # (F, 3) int32, local indices


@dataclass
class Scene:
    """A shot with every asset loaded and checked; cloth pieces concatenated."""

    shot: Shot
    shot_hash: str
    pieces: list[PieceArrays]
    positions: np.ndarray
    velocities: np.ndarray
    faces: np.ndarray
    face_uv: np.ndarray  # (F, 6)
    rest_positions: np.ndarray  # (N, 3) or (0, 3) for flat (uv) rest shapes
    face_material: dict[str, np.ndarray]
    fixed_pins: np.ndarray
    body_pin_vertices: np.ndarray
    body_pin_bodies: np.ndarray
    bodies: list[BodyArrays] = field(default_factory=list)
    # Pins that let go: (time in seconds after the first frame, vertices), and prescribed pin
    # paths: (vertices, positions per frame (frames, vertices, 3)).
    pin_releases: list[tuple[float, np.ndarray]] = field(default_factory=list)
    pin_paths: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)

    # The solver's bodies (weft.body_shells): a body mesh of several shells is split into them.
    _solver_bodies: list[SolverBody] | None = field(default=None, repr=False, compare=False)

    @property
    def vertex_count(self) -> int:
        return int(self.positions.shape[0])

    @property
    def solver_bodies(self) -> list[SolverBody]:
        """The bodies as the solver sees them (``weft.body_shells.split_bodies``), computed once."""
        if self._solver_bodies is None:
            self._solver_bodies = split_bodies(self.bodies)
        return self._solver_bodies

    @property
    def frame_count(self) -> int:
        return self.shot.frame_count


def triangle_uvs_from_positions(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per-corner (u, v) of each triangle flattened into its own plane, in metres.

    The warp direction u is world X projected onto the triangle (world Y where the triangle
    faces X); v completes a right-handed frame with the normal. Give explicit UVs for control.
    """
    p0, p1, p2 = (positions[faces[:, k]] for k in range(3))
    normal = np.cross(p1 - p0, p2 - p0)
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = normal / np.where(length > 0.0, length, 1.0)
    axis = np.where(np.abs(normal[:, :1]) > 0.9, np.array([[0.0, 1.0, 0.0]]), np.array([[1.0, 0.0, 0.0]]))
    u_dir = axis - np.sum(axis * normal, axis=1, keepdims=True) * normal
    u_dir /= np.maximum(np.linalg.norm(u_dir, axis=1, keepdims=True), 1e-300)
    v_dir = np.cross(normal, u_dir)
    uv = np.zeros((len(faces), 6))
    for k, p in enumerate((p0, p1, p2)):
        d = p - p0
        uv[:, 2 * k] = np.sum(d * u_dir, axis=1)
        uv[:, 2 * k + 1] = np.sum(d * v_dir, axis=1)
    return uv


def check_rest_areas(face_uv: np.ndarray, field_path: str) -> None:
    e1 = face_uv[:, 2:4] - face_uv[:, 0:2]
    e2 = face_uv[:, 4:6] - face_uv[:, 0:2]
    twice_area = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    scale = np.maximum(np.sum(e1 * e1, axis=1), np.sum(e2 * e2, axis=1))
    degenerate = ~(twice_area > 1e-12 * scale) | ~(twice_area > 1e-16)
    if degenerate.any():
        f = int(np.argmax(degenerate))
        raise ShotError(f"{field_path}[{f}]", "rest triangle has zero area")


def piece_self_collide(shot: Shot) -> list[bool]:
    """Per cloth piece: whether its faces take part in cloth/cloth collisions (see
    `collision_switches`)."""
    features = shot.features
    has_bodies = any(b.collide for b in shot.bodies)  # a body with collide: false switches nothing on
    self_default = (
        features.self_collision if features.self_collision is not None else (has_bodies or len(shot.cloth) > 1)
    )
    return [
        bool((p.self_collide if p.self_collide is not None else self_default) and features.self_collision is not False)
        for p in shot.cloth
    ]


def piece_body_collide(shot: Shot) -> list[bool]:
    """Per cloth piece: whether it collides with the bodies (see `collision_switches`)."""
    features = shot.features
    has_bodies = any(b.collide for b in shot.bodies)
    body_default = features.collisions if features.collisions is not None else has_bodies
    return [
        bool(body_default and (p.collide if p.collide is not None else True) and features.collisions is not False)
        for p in shot.cloth
    ]


def feature_summary(shot: Shot) -> dict[str, str]:
    """The physics a shot turns on, in words, decided from the shot alone (no assets read): the
    switches of `collision_switches` but GIA's automatic choice, which needs the meshes."""
    features = shot.features
    collide, self_collide = piece_body_collide(shot), piece_self_collide(shot)
    bodies = sum(1 for b in shot.bodies if b.collide)
    contact = any(collide) and bodies > 0
    enabled = contact or any(self_collide)
    pins = sum(len(pin.vertices) for piece in shot.cloth for pin in piece.pins)
    released = sum(len(pin.vertices) for piece in shot.cloth for pin in piece.pins if pin.release is not None)
    moving = sum(len(pin.vertices) for piece in shot.cloth for pin in piece.pins if pin.animation is not None)

    def of_pieces(flags: list[bool]) -> str:
        return f"on ({sum(flags)} of {len(flags)} pieces)" if any(flags) else "off"

    if not enabled:
        gia = "off"
    elif features.gia is None:
        gia = "auto: on (runs only while the cloth may be in intersection); body/body pinches when bodies meet"
    else:
        gia = "on" if features.gia else "off"
    wind = shot.environment.wind
    return {
        "cloth/body contact": f"{of_pieces(collide)}, {bodies} bodies" if contact else "off",
        "self-collision": of_pieces(self_collide),
        "CCD": "on" if enabled and (features.ccd if features.ccd is not None else True) else "off",
        "GIA": gia,
        "pins": (f"{pins} vertices" + (f", {moving} on paths" if moving else "")
                 + (f", {released} released during the shot" if released else "")) if pins else "none",
        "wind": "on" if wind is not None and any(wind.velocity) else "off",
        "air drag": f"{shot.environment.air_drag:g} kg/(m^2 s)" if shot.environment.air_drag else "off",
    }


def check_features(shot: Shot) -> None:
    """Refuse physics a shot asks for that this build does not provide (never ignore it)."""
    if shot.features.gia and not any(b.collide for b in shot.bodies) and not any(piece_self_collide(shot)):
        raise ShotError(
            "features.gia",
            "global intersection analysis needs a collidable body or self-collision (features.self_collision); "
            "this shot has neither, so there is nothing to analyse",
        )


def resolve_scene(shot: Shot, base_dir: str | Path) -> Scene:
    """Load every asset of a shot, check it, and concatenate the cloth pieces."""
    base_dir = Path(base_dir)
    check_features(shot)
    positions, velocities, faces, face_uv, rest = [], [], [], [], []
    materials: dict[str, list[np.ndarray]] = {
        k: [] for k in ("density", "stretch_warp", "stretch_weft", "shear", "bend", "damping")
    }
    pieces: list[PieceArrays] = []
    fixed_pins: list[int] = []
    pin_releases: list[tuple[float, np.ndarray]] = []
    pin_paths: list[tuple[np.ndarray, np.ndarray]] = []
    body_pin_vertices: list[int] = []
    body_pin_bodies: list[int] = []
    pin_groups: list[PinGroup] = []
    body_index = {b.name: i for i, b in enumerate(shot.bodies)}
    vertex_offset = face_offset = 0
    for i, piece in enumerate(shot.cloth):
        where = f"cloth[{i}]"
        vertices, piece_faces = load_mesh(base_dir, piece.mesh, where + ".mesh")
        unused = np.setdiff1d(np.arange(len(vertices)), np.unique(piece_faces))
        if len(unused):
            raise ShotError(
                where + ".mesh",
                f"{len(unused)} vertices belong to no face (first: {unused[:5].tolist()}); remove them",
            )
        if piece.rest.kind == "uv":
            if piece.rest.face_uvs is None:  # the OBJ's own vt, scaled to metres
                uv = load_obj_corner_uvs(base_dir, piece.mesh, piece_faces, where + ".rest") * piece.rest.uv_scale
            else:
                uv = _rest_array(base_dir, piece.rest.face_uvs, where + ".rest.face_uvs")
            if uv.shape not in {(len(piece_faces), 3, 2), (len(piece_faces), 6)}:
                raise ShotError(
                    where + ".rest.face_uvs", f"shape {uv.shape} does not match ({len(piece_faces)}, 3, 2)"
                )
            check_finite(uv.reshape(len(piece_faces), 6), where + ".rest.face_uvs")
            piece_uv = uv.reshape(len(piece_faces), 6)
            piece_rest = np.full((len(vertices), 3), np.nan)
            uv_field = where + (".rest.face_uvs" if piece.rest.face_uvs is not None else ".rest: OBJ vt of face")
        else:
            if piece.rest.kind == "positions":
                piece_rest = _rest_array(base_dir, piece.rest.positions, where + ".rest.positions")
                if piece_rest.shape != vertices.shape:
                    raise ShotError(
                        where + ".rest.positions",
                        f"shape {piece_rest.shape} does not match the mesh's vertices {vertices.shape}",
                    )
                check_finite(piece_rest, where + ".rest.positions")
                uv_field = where + ".rest.positions: triangle"
            else:
                piece_rest = vertices
                uv_field = where + ".mesh.faces"
            piece_uv = triangle_uvs_from_positions(piece_rest, piece_faces)
        check_rest_areas(piece_uv, uv_field)

        for j, pin in enumerate(piece.pins):
            indices = np.asarray(pin.vertices, dtype=np.int64)
            bad = (indices < 0) | (indices >= len(vertices))
            if bad.any():
                k = int(np.argmax(bad))
                raise ShotError(
                    f"{where}.pins[{j}].vertices[{k}]",
                    f"vertex {indices[k]} out of range (mesh has {len(vertices)} vertices)",
                )
            pin_field = f"{where}.pins[{j}]"
            group = PinGroup(pin_field, indices + vertex_offset, i, indices, attached=pin.body is not None,
                             release=pin.release)
            pin_groups.append(group)
            if pin.release is not None:
                duration = (shot.frame_range[1] - shot.frame_range[0]) / shot.fps
                if pin.release > duration:
                    raise ShotError(pin_field + ".release", f"{pin.release:g} s is after the shot's last frame "
                                    f"({duration:g} s after its first); leave it out to hold the pin")
                pin_releases.append((float(pin.release), indices + vertex_offset))
            if pin.animation is not None:
                path = _rest_array(base_dir, pin.animation, pin_field + ".animation")
                expected = (shot.frame_count, len(indices), 3)
                if path.shape != expected:
                    raise ShotError(pin_field + ".animation", f"shape {path.shape} is not {expected} "
                                    "(one position per shot frame for each pinned vertex)")
                check_finite(path, pin_field + ".animation")
                offset = np.abs(path[0] - vertices[indices]).max()
                if offset > 1e-6:
                    raise ShotError(pin_field + ".animation[0]", f"the first frame is {offset:.3g} m from where the "
                                    "pinned vertices start: a pin path starts at its vertices")
                pin_paths.append((indices + vertex_offset, path))
                group.path = path
            if pin.body is None:
                fixed_pins.extend((indices + vertex_offset).tolist())
            else:
                body_pin_vertices.extend((indices + vertex_offset).tolist())
                body_pin_bodies.extend([body_index[pin.body]] * len(indices))

        pieces.append(PieceArrays(piece.name, vertex_offset, len(vertices), face_offset, piece_faces.astype(np.int32)))
        positions.append(vertices)
        velocities.append(np.tile(np.asarray(piece.initial_velocity, dtype=np.float64), (len(vertices), 1)))
        faces.append(piece_faces + vertex_offset)
        face_uv.append(piece_uv)
        rest.append(piece_rest)
        m = piece.material
        for key in materials:
            materials[key].append(np.full(len(piece_faces), float(getattr(m, key))))
        vertex_offset += len(vertices)
        face_offset += len(piece_faces)

    all_pins = fixed_pins + body_pin_vertices
    if len(set(all_pins)) != len(all_pins):
        raise ShotError("cloth.pins", "a vertex is pinned more than once")

    bodies = [_load_body(base_dir, shot, i) for i in range(len(shot.bodies))]
    check_pin_room(shot, np.concatenate(positions), pin_groups, bodies, piece_body_collide(shot))
    all_flat = all(p.rest.kind == "uv" for p in shot.cloth)
    # Pieces with a flat (uv) rest shape have no 3D rest positions: NaN rows tell the solver
    # that their rest bending angles are zero.
    rest_positions = np.concatenate(rest) if not all_flat else np.zeros((0, 3))
    return Scene(
        shot=shot,
        shot_hash=shot_hash(shot, base_dir),
        pieces=pieces,
        positions=np.ascontiguousarray(np.concatenate(positions)),
        velocities=np.ascontiguousarray(np.concatenate(velocities)),
        faces=np.ascontiguousarray(np.concatenate(faces).astype(np.int32)),
        face_uv=np.ascontiguousarray(np.concatenate(face_uv)),
        rest_positions=np.ascontiguousarray(rest_positions),
        face_material={k: np.concatenate(v) for k, v in materials.items()},
        fixed_pins=np.asarray(fixed_pins, dtype=np.int32),
        body_pin_vertices=np.asarray(body_pin_vertices, dtype=np.int32),
        body_pin_bodies=np.asarray(body_pin_bodies, dtype=np.int32),
        pin_releases=pin_releases,
        pin_paths=pin_paths,
        bodies=bodies,
    )


def _rest_array(base_dir: Path, value: Any, field_path: str) -> np.ndarray:
    if isinstance(value, ArrayAsset):
        return load_array(base_dir, value, field_path)
    return np.asarray(value, dtype=np.float64)


def _load_body(base_dir: Path, shot: Shot, i: int) -> BodyArrays:
    body = shot.bodies[i]
    where = f"bodies[{i}]"
    vertices, faces = load_mesh(base_dir, body.mesh, where + ".mesh")
    count = shot.frame_count
    if body.animation is None:
        frames = np.broadcast_to(vertices, (count, *vertices.shape))
    else:
        frames = load_array(base_dir, body.animation, where + ".animation")
        if frames.ndim != 3 or frames.shape[2] != 3:
            raise ShotError(where + ".animation", f"shape {frames.shape} is not (frames, vertices, 3)")
        if frames.shape[1] != len(vertices):
            raise ShotError(
                where + ".animation",
                f"has {frames.shape[1]} vertices per frame but the body mesh has {len(vertices)}",
            )
        check_finite(frames, where + ".animation")
        frames = retime_animation(frames, body.animation_fps or shot.fps, body.frame_offset, shot, where)
    return BodyArrays(body.name, faces.astype(np.int32), frames)


def retime_animation(samples: np.ndarray, sample_fps: float, frame_offset: float, shot: Shot,
                     where: str) -> np.ndarray:
    """One pose per shot frame from an animation's samples: shot frame index i plays sample
    (i - frame_offset) * sample_fps / shot.fps, linearly interpolated between the two nearest
    samples. Every shot frame must fall within the samples (no silent hold of the first or last
    pose)."""
    count = shot.frame_count
    at = (np.arange(count) - frame_offset) * (sample_fps / shot.fps)
    last = len(samples) - 1
    if at[0] < -1e-9 or at[-1] > last + 1e-9:
        first_frame = shot.frame_range[0] + frame_offset
        last_frame = first_frame + last * shot.fps / sample_fps
        raise ShotError(where + ".animation", f"{len(samples)} samples at {sample_fps:g} per second cover shot frames "
                        f"{first_frame:g}-{last_frame:g} (frame_offset {frame_offset:g}), but frame_range is "
                        f"{list(shot.frame_range)}: give samples for every frame, or change frame_offset/animation_fps")
    at = np.clip(at, 0.0, last)
    below = np.minimum(np.floor(at).astype(np.int64), max(last - 1, 0))
    weight = (at - below)[:, None, None]
    above = np.minimum(below + 1, last)
    if np.all(weight == 0.0) and np.array_equal(below, np.arange(count)):
        return samples[:count]  # one sample per frame, from the first: the samples themselves
    return (1.0 - weight) * samples[below] + weight * samples[above]


def solver_pin_bodies(scene: Scene) -> np.ndarray:
    """Per body-pinned cloth vertex, the solver body it is attached to: its body, or of a body
    split into shells (``Scene.solver_bodies``) the shell nearest the vertex at the start."""
    out = np.empty(len(scene.body_pin_bodies), dtype=np.int32)
    for body in np.unique(scene.body_pin_bodies):
        rows = np.flatnonzero(scene.body_pin_bodies == body)
        points = scene.positions[scene.body_pin_vertices[rows]]
        out[rows] = shell_of_nearest_point(scene.solver_bodies, scene.bodies, int(body), points)
    return out


def build_setup(scene: Scene, threads: int = 1, linear_system: str | None = None) -> Any:
    """The C++ SimulationSetup for a scene. linear_system ('fast' or 'reference') overrides the shot's."""
    from weft import _solver

    shot = scene.shot
    setup = _solver.SimulationSetup()
    setup.positions = scene.positions
    setup.velocities = scene.velocities
    setup.faces = scene.faces
    setup.face_uv = scene.face_uv
    setup.rest_positions = scene.rest_positions
    setup.face_density = scene.face_material["density"]
    setup.face_stretch_warp = scene.face_material["stretch_warp"]
    setup.face_stretch_weft = scene.face_material["stretch_weft"]
    setup.face_shear = scene.face_material["shear"]
    setup.face_bend = scene.face_material["bend"]
    setup.face_damping = scene.face_material["damping"]
    if any(piece.material.stretch_knee is not None for piece in scene.shot.cloth):  # biphasic stretch somewhere
        counts = [len(p.faces) for p in scene.pieces]
        materials = [piece.material for piece in scene.shot.cloth]
        setup.face_stretch_knee = np.repeat([np.inf if m.stretch_knee is None else m.stretch_knee for m in materials],
                                            counts).astype(np.float64)
        setup.face_stretch_ratio = np.repeat([m.stretch_knee_ratio for m in materials], counts).astype(np.float64)
    env = _solver.Environment()
    env.gravity = np.asarray(shot.environment.gravity, dtype=np.float64)
    env.air_drag = shot.environment.air_drag
    if shot.environment.wind is not None:
        env.wind_velocity = np.asarray(shot.environment.wind.velocity, dtype=np.float64)
        env.gust_amplitude = shot.environment.wind.gust_amplitude
        env.gust_frequency = shot.environment.wind.gust_frequency
    setup.environment = env
    setup.fixed_pin_vertices = scene.fixed_pins.tolist()
    setup.body_pin_vertices = scene.body_pin_vertices.tolist()
    setup.body_pin_bodies = solver_pin_bodies(scene).tolist()
    setup.body_faces = [b.faces for b in scene.solver_bodies]
    setup.body_positions = [b.frame(scene.bodies, 0) for b in scene.solver_bodies]
    solver = _solver.SolverSettings()
    solver.cg_tolerance = shot.solver.cg_tolerance
    solver.cg_max_iterations = shot.solver.cg_max_iterations
    solver.max_substep_halvings = shot.solver.max_substep_halvings
    solver.max_step_strain = shot.solver.max_step_strain
    solver.threads = threads
    solver.linear_system = {"fast": _solver.LinearSystemKind.FAST, "reference": _solver.LinearSystemKind.REFERENCE}[
        linear_system or shot.solver.linear_system
    ]
    solver.matrix_precision = {"float32": _solver.MatrixPrecision.FLOAT32, "float64": _solver.MatrixPrecision.FLOAT64}[
        shot.solver.matrix_precision
    ]
    solver.preconditioner = {
        "auto": _solver.Preconditioner.AUTO,
        "block_jacobi": _solver.Preconditioner.BLOCK_JACOBI,
        "multigrid": _solver.Preconditioner.MULTIGRID,
    }[shot.solver.preconditioner]
    setup.solver = solver
    setup.collision = collision_settings(scene)
    return setup


def collision_switches(scene: Scene) -> dict[str, Any]:
    """Resolve the shot's collision switches (None means: decided by what the scene contains).

    - Cloth/body contact (``features.collisions``, per piece ``collide``, per body ``collide``):
      on when the scene has a collidable body (a body with ``collide: false`` switches nothing on).
    - Articulated characters (per body ``group``, ``body_groups``): parts of one character may
      overlap at joints; a pair of parts is never a pinch and does not switch GIA on.
    - Self-collision (``features.self_collision``, per piece ``self_collide``): on when the
      scene has a collidable body or more than one cloth piece (cloth that drapes, folds or layers); off
      for a single free piece such as a flag, which then pays nothing for it. Cloth/cloth pairs
      are tested between faces that both have self-collision on, also across pieces.
    - CCD (``features.ccd``): on whenever any collision is on.
    - GIA (``features.gia``): recovery of cloth inside or through closed bodies, body/body
      pinch states (CCD off for cloth caught where two collidable bodies intersect each other)
      and cloth/cloth untangling (with self-collision). None means on whenever there is a
      collidable body or self-collision (``gia`` -1): the recovery runs only in steps that may
      start in intersection (the first, and after a frame or step that left some), so a clean
      shot pays one analysis and moves bit for bit as with GIA off, and cloth that a pinch or an
      exhausted fail-safe leaves in intersection can recover. Body/body pinch tracking (every
      step) is added (``gia`` 1) when two collidable bodies, not parts of one character,
      intersect each other at some animation frame (``bodies_intersect_each_other``: exact test
      per frame, bounding boxes first). Off when there is neither a collidable body nor
      self-collision.
    A switch set to false at the scene level turns the feature off for every piece.
    """
    shot = scene.shot
    features = shot.features
    piece_collide = piece_body_collide(shot)
    piece_self = piece_self_collide(shot)
    body_collide = [bool(shot.bodies[b.body].collide) for b in scene.solver_bodies]
    any_body = any(piece_collide) and any(body_collide)
    enabled = any_body or any(piece_self)
    ccd = enabled and (features.ccd if features.ccd is not None else True)
    gia = (-1 if features.gia is None else int(bool(features.gia))) if (any_body or any(piece_self)) else 0
    groups = body_groups(scene, body_collide) if any_body else [-1] * len(body_collide)
    if gia == -1 and any_body and bodies_intersect_each_other(scene, body_collide, groups):
        gia = 1
    return {
        "enabled": enabled,
        "ccd": ccd,
        "gia": gia,
        "piece_collide": piece_collide,
        "piece_self_collide": piece_self,
        "body_collide": body_collide,
        "body_group": groups,
    }


def _intersect(xa: np.ndarray, a: SolverBody, xb: np.ndarray, b: SolverBody) -> bool:
    """Whether solver bodies a and b, at positions xa and xb, intersect each other."""
    from weft import _solver

    return bool(_solver.body_intersection(xa, a.faces, xb, b.faces)["intersecting"])


def body_groups(scene: Scene, body_collide: list[bool]) -> list[int]:
    """Per solver body (``Scene.solver_bodies``; body_collide likewise): the articulated
    character it is a part of (an index), or -1 for none.

    Bodies with the same ``group`` name form one character, and so do the shells of one body
    mesh (``weft.body_shells``). Collidable bodies without a group that intersect each other at
    the first frame are joined into one (the usual collision proxy of a character: closed parts
    overlapping at the joints). Pairs of parts of one character are never body/body pinches, and
    their meeting does not switch GIA on."""
    bodies = scene.solver_bodies
    specs = [scene.shot.bodies[b.body] for b in bodies]
    named: dict[str, int] = {}
    whole: dict[int, int] = {}
    parent = list(range(len(bodies)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, (body, spec) in enumerate(zip(bodies, specs)):
        if spec.group is not None:
            j = named.setdefault(spec.group, i)
            parent[find(i)] = find(j)
        j = whole.setdefault(body.body, i)  # shells of one mesh
        parent[find(i)] = find(j)
    free = [i for i, spec in enumerate(specs) if spec.group is None and body_collide[i]]
    first = {i: bodies[i].frame(scene.bodies, 0) for i in free}
    lo = {i: first[i].min(axis=0) for i in free}
    hi = {i: first[i].max(axis=0) for i in free}
    for a_index, i in enumerate(free):
        for j in free[a_index + 1:]:
            if find(i) == find(j) or not np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i])):
                continue
            if _intersect(first[i], bodies[i], first[j], bodies[j]):
                parent[max(find(i), find(j))] = min(find(i), find(j))
    roots = [find(i) for i in range(len(bodies))]
    size = {r: roots.count(r) for r in roots}
    return [r if size[r] > 1 else -1 for r in roots]


def bodies_intersect_each_other(scene: Scene, body_collide: list[bool] | None = None,
                                groups: list[int] | None = None) -> bool:
    """Whether two collidable solver bodies (``Scene.solver_bodies``; body_collide and groups
    likewise) that are not parts of one character (``body_groups``) intersect each other
    (surfaces cross, or a vertex of one is inside the other, closed, body) at some animation
    frame. Exact (``_solver.body_intersection``); frames whose bounding boxes do not overlap are
    skipped, and a frame where both bodies are where they were at the last tested frame reuses
    its answer, so long or static shots stay cheap. Motion between keyframes is not looked at."""
    bodies = scene.solver_bodies
    collide = body_collide or [True] * len(bodies)
    groups = groups or [-1] * len(bodies)
    ids = [i for i, c in enumerate(collide) if c]
    if len(ids) < 2:
        return False

    def track(i: int) -> np.ndarray:  # (frames, V, 3) of solver body i
        frames = scene.bodies[bodies[i].body].frames
        return frames if bodies[i].vertices is None else frames[:, bodies[i].vertices]

    lo = {i: track(i).min(axis=1) for i in ids}  # (frames, 3) per body
    hi = {i: track(i).max(axis=1) for i in ids}
    for a_index, i in enumerate(ids):
        for j in ids[a_index + 1:]:
            if groups[i] >= 0 and groups[i] == groups[j]:
                continue
            overlap = np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=1)
            last: tuple[np.ndarray, np.ndarray] | None = None
            for k in np.flatnonzero(overlap):
                xa, xb = bodies[i].frame(scene.bodies, int(k)), bodies[j].frame(scene.bodies, int(k))
                if last is not None and np.array_equal(xa, last[0]) and np.array_equal(xb, last[1]):
                    continue  # same as the last tested frame: not intersecting
                if _intersect(xa, bodies[i], xb, bodies[j]):
                    return True
                last = (xa, xb)
    return False


def collision_settings(scene: Scene) -> Any:
    """The C++ CollisionSettings: per-face switches, thickness and friction from the pieces."""
    from weft import _solver

    switches = collision_switches(scene)
    settings = _solver.CollisionSettings()
    settings.enabled = switches["enabled"]
    if not settings.enabled:
        return settings
    settings.ccd = switches["ccd"]
    settings.gia = switches["gia"]
    counts = [len(p.faces) for p in scene.pieces]
    materials = [piece.material for piece in scene.shot.cloth]
    settings.face_collide = np.repeat(switches["piece_collide"], counts).astype(bool).tolist()
    settings.face_self_collide = np.repeat(switches["piece_self_collide"], counts).astype(bool).tolist()
    settings.body_collide = switches["body_collide"]
    settings.body_group = switches["body_group"]
    if any(b.collision_offset for b in scene.shot.bodies):
        settings.body_offset = [float(scene.shot.bodies[b.body].collision_offset) for b in scene.solver_bodies]
    settings.face_thickness = np.repeat([m.thickness for m in materials], counts).astype(np.float64)
    settings.face_friction = np.repeat([m.friction for m in materials], counts).astype(np.float64)
    return settings
