"""The shot: what a user asks weft to simulate.

SI units throughout (metres, kilograms, seconds). A shot is a JSON or YAML document; large
arrays live in asset files referenced by path relative to the shot file (meshes as OBJ/PLY,
animation as HDF5 or NPZ arrays), or may be given inline for small scenes and tests.

Models are strict: unknown fields are rejected, numbers must be finite, and every constraint
that can be checked without loading assets is checked here. Checks that need the assets (index
ranges, degenerate triangles, animation shapes) are done by ``weft.solver_setup`` and reported with the
same field paths.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from api_schemas.materials import PresetName, apply_preset

SHOT_FORMAT_VERSION = 1

FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
PositiveFloat = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
Vec3 = tuple[FiniteFloat, FiniteFloat, FiniteFloat]
Vec2 = tuple[FiniteFloat, FiniteFloat]
VertexIndex = Annotated[int, Field(ge=0, lt=2**31, description="0-based vertex index")]
Triangle = tuple[VertexIndex, VertexIndex, VertexIndex]
Name = Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")]
AssetPath = Annotated[str, Field(min_length=1, max_length=256)]


class StrictModel(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)


class ArrayAsset(StrictModel):
    """An array stored in an HDF5 (.h5/.hdf5) or NumPy (.npz/.npy) file next to the shot."""

    path: AssetPath
    key: str | None = Field(
        default=None, description="Dataset name (HDF5) or array name (NPZ); default 'positions'."
    )

    @field_validator("path")
    @classmethod
    def _relative_path(cls, value: str) -> str:
        return _check_relative_path(value)


def _check_relative_path(value: str) -> str:
    if value.startswith(("/", "\\")) or ":" in value:
        raise ValueError("asset paths must be relative to the shot file")
    if any(part == ".." for part in value.replace("\\", "/").split("/")):
        raise ValueError("asset paths may not leave the shot's directory ('..')")
    return value


class MeshSource(StrictModel):
    """A triangle mesh: a file (OBJ/PLY, read as-is without merging vertices) or inline arrays."""

    path: AssetPath | None = None
    vertices: list[Vec3] | None = None
    faces: list[Triangle] | None = None

    @field_validator("path")
    @classmethod
    def _relative_path(cls, value: str | None) -> str | None:
        return None if value is None else _check_relative_path(value)

    @model_validator(mode="after")
    def _one_source(self) -> MeshSource:
        inline = self.vertices is not None or self.faces is not None
        if self.path is not None and inline:
            raise ValueError("give either 'path' or inline 'vertices' and 'faces', not both")
        if self.path is None and (self.vertices is None or self.faces is None):
            raise ValueError("give 'path' to a mesh file, or both 'vertices' and 'faces'")
        return self


class RestShape(StrictModel):
    """How the unstretched cloth is defined.

    - ``initial``: the mesh's initial positions are at rest (flattened per triangle).
    - ``positions``: per-vertex rest positions (a 3D rest shape; its dihedral angles are the
      rest bending angles).
    - ``uv``: per-corner (u, v) coordinates in metres, shape (faces, 3, 2), e.g. sewing-pattern
      panels; u is the warp direction, v the weft. The rest shape is flat. Without
      ``face_uvs``, the mesh's own OBJ ``vt`` coordinates, times ``uv_scale`` (metres per UV
      unit: 1 when the pattern's UVs are in metres, 0.01 in centimetres).
    """

    kind: Literal["initial", "positions", "uv"] = "initial"
    positions: list[Vec3] | ArrayAsset | None = None
    face_uvs: list[tuple[Vec2, Vec2, Vec2]] | ArrayAsset | None = None
    uv_scale: PositiveFloat = Field(1.0, le=1e6, description="Metres per UV unit of the OBJ's vt (kind 'uv' without "
                                                             "face_uvs).")

    @model_validator(mode="after")
    def _data_matches_kind(self) -> RestShape:
        if self.kind == "positions" and self.positions is None:
            raise ValueError("kind 'positions' needs 'positions'")
        if self.uv_scale != 1.0 and (self.kind != "uv" or self.face_uvs is not None):
            raise ValueError("'uv_scale' scales an OBJ's vt: only with kind 'uv' and no 'face_uvs'")
        if self.kind != "positions" and self.positions is not None:
            raise ValueError(f"'positions' is only used with kind 'positions', not '{self.kind}'")
        if self.kind != "uv" and self.face_uvs is not None:
            raise ValueError(f"'face_uvs' is only used with kind 'uv', not '{self.kind}'")
        return self


class Material(StrictModel):
    """Cloth material. Stiffnesses are membrane moduli (energy per rest area per unit strain^2).
    A ``preset`` (api_schemas/materials.py) fills the fabric fields the document leaves out."""

    preset: PresetName | None = Field(
        None, description="Named fabric (cotton, denim: measured, Wang et al. 2011; silk, leather: estimates) whose "
        "density, stretch, shear and bend fill the fields not given here; `weft materials` lists them with sources.")
    density: PositiveFloat = Field(0.15, description="Areal density, kg/m^2.", le=100.0)
    stretch_warp: PositiveFloat = Field(2000.0, description="Stretch stiffness along u (warp), N/m.")
    stretch_weft: PositiveFloat = Field(2000.0, description="Stretch stiffness along v (weft), N/m.")
    shear: NonNegativeFloat = Field(200.0, description="Shear stiffness, N/m.")
    bend: NonNegativeFloat = Field(1e-5, description="Bending stiffness, N m.")
    damping: NonNegativeFloat = Field(
        0.002, description="Stiffness-proportional damping time along each condition's gradient, s.", le=10.0
    )
    stretch_knee: NonNegativeFloat | None = Field(
        None, le=10.0, description="Biphasic stretch: the strain (0.03 = 3 %) past which the fabric stiffens; none: "
        "linear. Woven fabric is soft while its crimp straightens, then its yarns themselves stretch.")
    stretch_knee_ratio: float = Field(
        10.0, ge=1.0, le=1e4, description="Biphasic stretch: stiffness past the knee over stiffness before it.")
    thickness: PositiveFloat = Field(0.002, description="Collision thickness, m.", le=1.0)
    friction: NonNegativeFloat = Field(0.3, description="Coulomb friction coefficient.", le=10.0)

    @model_validator(mode="before")
    @classmethod
    def _fill_from_preset(cls, data: Any) -> Any:
        return apply_preset(data)


class Pin(StrictModel):
    """Vertices held in place: fixed at their initial positions, moved along a prescribed path
    (``animation``), or attached to the closest point of an animated body (keeping their offset
    in that triangle's frame); until ``release``, if given, then free."""

    vertices: list[VertexIndex] = Field(min_length=1)
    body: Name | None = Field(default=None, description="Name of the body to follow; none: fixed in space.")
    release: NonNegativeFloat | None = Field(
        default=None, le=1e7, description="Seconds after the shot's first frame at which the pin lets go (at the first "
        "frame that starts at or after it); none: held for the whole shot.")
    animation: list[list[Vec3]] | ArrayAsset | None = Field(
        default=None, description="Positions of the pinned vertices per shot frame, shape (frames, vertices, 3); "
        "the pin moves linearly between frames. Only for a pin fixed in space (no body).")

    @model_validator(mode="after")
    def _animation_without_body(self) -> Pin:
        if self.animation is not None and self.body is not None:
            raise ValueError("a pin follows either a body or its own animation, not both")
        return self


class ClothPiece(StrictModel):
    name: Name
    mesh: MeshSource
    rest: RestShape = RestShape()
    material: Material = Material()
    pins: list[Pin] = Field(default_factory=list)
    initial_velocity: Vec3 = (0.0, 0.0, 0.0)
    collide: bool | None = Field(default=None, description="Collide with bodies; default: when bodies exist.")
    self_collide: bool | None = Field(default=None, description="Self-collision; default: scene switch.")


class Body(StrictModel):
    """A kinematic (animated) triangle mesh. Without animation it stays where its mesh is."""

    name: Name
    mesh: MeshSource
    animation: ArrayAsset | None = Field(
        default=None, description="Vertex positions per sample, shape (samples, vertices, 3). By default one sample "
        "per shot frame, sample 0 at the first frame; animation_fps and frame_offset retime it.")
    animation_fps: PositiveFloat | None = Field(
        default=None, le=100_000.0, description="Samples per second of the animation (default: the shot's fps). "
        "Between samples the body moves linearly; sub-frame samples are read at the frame times.")
    frame_offset: float = Field(
        0.0, ge=-1e6, le=1e6, description="Shot frames from the first frame of frame_range to the animation's sample "
        "0 (negative: the animation started before the shot).")
    collide: bool = True
    collision_offset: NonNegativeFloat = Field(
        0.0, le=1.0, description="Extra distance, m, the cloth keeps from this body on top of its own thickness (the "
        "body's outer thickness: a collision proxy smaller than the skin it stands for).")
    group: Name | None = Field(
        default=None,
        description=(
            "Articulated character this body is a part of. Parts of one character may overlap at "
            "their joints: cloth stays outside all of them and their overlap is never a pinch; where "
            "two parts' surfaces close on cloth (nearer than two cloth thicknesses, an arm along the "
            "torso) the cloth there is squeezed as in a pinch. Unset: bodies that intersect each "
            "other at the first frame are joined automatically. A body mesh made of several separate "
            "shells (2 to 64) is split into them, parts of one character."
        ),
    )


class Wind(StrictModel):
    velocity: Vec3 = (0.0, 0.0, 0.0)
    gust_amplitude: NonNegativeFloat = Field(0.0, description="Relative gust strength (0: steady).", le=10.0)
    gust_frequency: NonNegativeFloat = Field(0.0, description="Gusts per second.", le=1000.0)


class Environment(StrictModel):
    gravity: Vec3 = (0.0, -9.81, 0.0)
    air_drag: NonNegativeFloat = Field(0.0, description="Linear air drag, kg/(m^2 s), on velocity relative to wind.")
    wind: Wind | None = None


class SolverSettings(StrictModel):
    cg_tolerance: PositiveFloat = Field(
        1e-3, lt=1.0,
        description="Relative residual ||r|| / ||S(b - A z)|| at which CG stops. 1e-3: on a swinging sheet 0.06 mm RMS "
        "(0.3 mm max) from a 1e-8 solve after 24 frames, and in contact within the scene's own sensitivity "
        "(`python -m bench.tolerance`, docs/linear-system.md); Blender's cloth stops at 1e-2.")
    cg_max_iterations: int = Field(500, ge=1, le=100_000)
    max_substep_halvings: int = Field(
        2, ge=0, le=6,
        description=("Adaptive substepping: a substep whose collision stage leaves pairs unresolved (or "
                     "overstretches an edge, see max_step_strain) is redone as two halves, at most this many "
                     "halvings deep (0: never); the frame's next substep then starts one level deeper (down to "
                     "this many halvings, whose pieces are taken as they end), and one taken without a halving "
                     "lets the next go one level up again. From 2, a frame in which a "
                     "collidable closed body moves faster than its own thickness through the cloth it meets "
                     "within one substep (a thin limb at metres per second) starts its substeps halved, up to "
                     "one level less than this."),
    )
    max_step_strain: float = Field(
        1.5, ge=0.0, le=100.0,
        description=("A substep that takes an edge from within the strain limit (1.4) to more than this many times "
                     "its rest length is redone as two halves, unless GIA is recovering or a pinch is engaged (0: "
                     "never; else above 1). On a limb moving through cloth at metres per second the impulses "
                     "stretched single edges to 3.7x in one step, and cloth falling at 5 m/s onto a sphere to "
                     "1.67x (docs/collisions.md)."),
    )
    matrix_precision: Literal["float64", "float32"] = Field(
        "float32", description="Value type of the fast path's block matrix (the reference path is always float64)."
    )
    linear_system: Literal["reference", "fast"] = Field(
        "fast",
        description="Assembly and solve path: 'fast' (fixed-pattern BCRS, RCM, pre-filtered PCG) or 'reference' "
        "(Eigen sparse matrix, Eigen ConjugateGradient); see docs/linear-system.md.",
    )
    @field_validator("max_step_strain")
    @classmethod
    def _step_strain_off_or_above_one(cls, value: float) -> float:
        if value != 0.0 and value <= 1.0:
            raise ValueError("must be 0 (off) or above 1 (a length over the rest length)")
        return value

    preconditioner: Literal["auto", "multigrid", "block_jacobi"] = Field(
        "auto",
        description="CG preconditioner of the fast path: 'multigrid' (smoothed-aggregation algebraic multigrid, "
        "Tamstorf et al. 2015: a few tens of iterations instead of hundreds, plus a per-substep setup), "
        "'block_jacobi' (3x3 block Jacobi, cheap per iteration), or 'auto' (multigrid from the cloth size at which "
        "it measured faster, block Jacobi below; see docs/multigrid.md). The reference path ignores it.",
    )


class Features(StrictModel):
    """Physics switches. None means: decided from what the scene contains."""

    collisions: bool | None = None
    self_collision: bool | None = None
    ccd: bool | None = None
    gia: bool | None = None


class Outputs(StrictModel):
    """What a run writes besides the cloth: body motion in the cache, a USD file (service)."""

    usd: bool = Field(False, description="Also write the cloth as USD (cache.usd next to the cache; "
                                         "GET /v1/jobs/{id}/usd), with the bodies when body_motion is on.")
    body_motion: bool = Field(False, description="Keep every body's vertex positions per frame in the cache "
                                                 "(bodies/<name>/positions), so the cache alone shows the scene and "
                                                 "the USD export includes the bodies. Costs 12 bytes per body vertex "
                                                 "and frame.")


class Shot(StrictModel):
    format_version: Literal[1] = SHOT_FORMAT_VERSION
    name: Name
    fps: PositiveFloat = Field(24.0, le=10_000.0)
    frame_range: tuple[int, int] = Field(
        (1, 48), description="First and last frame, inclusive. The first frame is the initial state."
    )
    substeps: int = Field(4, ge=1, le=1000, description="Implicit steps per frame.")
    environment: Environment = Environment()
    cloth: list[ClothPiece] = Field(min_length=1)
    bodies: list[Body] = Field(default_factory=list)
    solver: SolverSettings = SolverSettings()
    features: Features = Features()
    outputs: Outputs = Outputs()

    @field_validator("frame_range")
    @classmethod
    def _ordered_range(cls, value: tuple[int, int]) -> tuple[int, int]:
        first, last = value
        if last <= first:
            raise ValueError(f"last frame ({last}) must be after the first ({first})")
        if last - first > 1_000_000:
            raise ValueError("at most 1,000,000 frames")
        return value

    @model_validator(mode="after")
    def _names_and_references(self) -> Shot:
        _unique([c.name for c in self.cloth], "cloth")
        _unique([b.name for b in self.bodies], "bodies")
        body_names = {b.name for b in self.bodies}
        for i, piece in enumerate(self.cloth):
            for j, pin in enumerate(piece.pins):
                if pin.body is not None and pin.body not in body_names:
                    raise ValueError(f"cloth[{i}].pins[{j}].body: no body named '{pin.body}'")
        return self

    @property
    def frame_count(self) -> int:
        return self.frame_range[1] - self.frame_range[0] + 1


def _unique(names: list[str], field: str) -> None:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise ValueError(f"{field}: duplicate name '{name}'")
        seen.add(name)
