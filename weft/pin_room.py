"""Offsets that leave no room: pins that hold cloth closer to a colliding body than the cloth
keeps from it, found when a shot is resolved (``weft.solver_setup.resolve_scene``) and reported
as a ShotError naming the pin, the body, the frame and both distances (docs/collisions.md)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from api_schemas import Shot
from weft.geometry import distances_within
from weft.shot import ShotError


class BodyFrames(Protocol):
    """What the check reads of a body (``solver_setup.BodyArrays``): its triangles and its
    vertex positions per keyframe (a broadcast view for a body that does not move)."""

    faces: np.ndarray
    frames: np.ndarray


@dataclass
class PinGroup:
    """One pins[] entry as check_pin_room sees it: its field path, its vertices (global and in
    its piece), its piece, how it holds them (attached to a body, a path of positions per
    keyframe) and its release time."""

    field: str
    vertices: np.ndarray
    piece: int
    local: np.ndarray
    attached: bool = False
    release: float | None = None
    path: np.ndarray | None = None



def check_pin_room(shot: Shot, positions: np.ndarray, pin_groups: list[PinGroup], bodies: Sequence[BodyFrames],
                   collides: list[bool]) -> None:
    """Offsets that leave no room: a pin that holds cloth closer to a colliding body, at any frame
    while it holds, than the cloth must keep from it (its thickness plus the body's
    collision_offset). The pin holds its vertices there, collisions push the cloth out, and
    neither can give: a ShotError naming the pin, the body, the frame and both distances.

    Checked at every keyframe the pin holds (until its release) where the pin's targets or the
    body moved; a pin attached to a body moves with it, so it is checked at the first frame
    only. Keyframes where no pinned vertex is within reach of the body's box are skipped, and
    exact distances are computed only for pinned vertices and body faces within reach of each
    other (``distances_within``). ``collides``: per cloth piece, whether it collides with
    bodies at all (``solver_setup.piece_body_collide``)."""
    if not pin_groups or not bodies:
        return
    dt = 1.0 / shot.fps
    for group in pin_groups:
        if not collides[group.piece]:
            continue
        # Keyframe f is held when the frame that ends there starts before the release.
        held = shot.frame_count if group.release is None else \
            int(np.sum((np.arange(shot.frame_count) - 1) * dt < group.release - 1e-9 * dt))
        for k, (spec, body) in enumerate(zip(shot.bodies, bodies)):
            if not spec.collide:
                continue
            keep = shot.cloth[group.piece].material.thickness + spec.collision_offset
            frames = [0]
            if not group.attached:
                body_moves = body.frames.strides[0] != 0 and held > 1 and bool(np.any(body.frames[1:held] != body.frames[0]))
                if body_moves or group.path is not None:
                    frames = range(held)
            for f in frames:
                points = positions[group.vertices] if group.path is None else group.path[f]
                x = np.asarray(body.frames[f], dtype=np.float64)
                reach = (points >= x.min(axis=0) - keep).all(axis=1) & (points <= x.max(axis=0) + keep).all(axis=1)
                if not reach.any():
                    continue
                near = np.full(len(points), np.inf)
                near[reach] = distances_within(points[reach], x, body.faces, keep)
                closest = int(np.argmin(near))
                # A pin placed exactly at the distance (to rounding) is fine.
                if near[closest] < keep * (1.0 - 1e-6):
                    inside = int(np.sum(near < keep * (1.0 - 1e-6)))
                    offset = f" + bodies[{k}].collision_offset {spec.collision_offset * 1000:g} mm" \
                        if spec.collision_offset else ""
                    when = "at the first frame" if f == 0 else f"at frame {shot.frame_range[0] + f}"
                    raise ShotError(
                        group.field, f"{inside} pinned vertices are held closer to body {spec.name!r} than the cloth "
                        f"keeps from it ({keep * 1000:.3g} mm = material.thickness "
                        f"{shot.cloth[group.piece].material.thickness * 1000:g} mm{offset}); its vertex "
                        f"{int(group.local[closest])} is {near[closest] * 1000:.3g} mm away {when}: the pin leaves the "
                        "cloth no room. Move the pinned vertices (or their path) out, or lower the thickness or the "
                        "offset")
