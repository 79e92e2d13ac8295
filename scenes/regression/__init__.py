"""Regression scenes (issue 14): small procedural shots, one per feature and failure class, that
`weft regress` submits to the service and judges against stored references.

Each scene is a builder `f(directory) -> shot document` (assets written into `directory`) and a
folder `scenes/regression/<name>/` holding its thresholds (`thresholds.yaml`, written by hand)
and its reference (`reference.npz` and `reference.json`, written by `weft regress
--update-references`). Each declares only the features it needs: a scene without bodies or
self-contact switches nothing on.

| scene | what it guards |
|---|---|
| free_fall | integrator, gravity: analytic y(t) = y0 - g t^2 / 2 |
| hanging_strip | stretch, pins: a strip hanging from its top edge settles |
| pendulum_sheet | bending, damping: a sheet pinned at one corner swings |
| flag_wind | wind and air drag on a flag pinned at two corners |
| drape_sphere | cloth/body contact in the solve, friction, self-collision culling |
| sleeve_swing | contact with a fast limb, strain limit, impact zones |
| box_pinch | cloth pinched between two closing boxes (GIA pinch rules) |
| twist | self-contact of a sheet twisted a full turn |
| through_body | a start with cloth through a body (GIA recovery) |
| self_tangled | a start with one sheet pushed through another (cloth/cloth GIA) |
| thin_limb | a thin limb moving fast through a hanging sheet |
| large_sheet | a 224 x 224 (50,176 vertex) sheet: the multigrid path at size |
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from scenes.builders import sheet_shot
from scenes.collision import box_pinch_shot, sleeve_shot, twist_shot
from scenes.contact import drape_sphere, thin_limb
from scenes.gia import through_shot, two_sheets_shot

FOLDER = Path(__file__).resolve().parent


def free_fall(directory: Path) -> dict[str, Any]:
    """A 6 x 6 sheet 0.5 m wide falling freely (no drag, no pins) for 12 frames."""
    return sheet_shot("free_fall", 6, 6, 0.5, 0.5, plane="xz", origin=(0.0, 2.0, 0.0), frames=12)


def hanging_strip(directory: Path) -> dict[str, Any]:
    """A 0.1 x 0.6 m strip (4 x 19 vertices) pinned along its top edge, released straight."""
    return sheet_shot("hanging_strip", 4, 19, 0.1, 0.6, plane="xy", pins=[0, 1, 2, 3], frames=24, air_drag=0.2,
                      material={"damping": 0.02})


def pendulum_sheet(directory: Path) -> dict[str, Any]:
    """A horizontal 0.4 m sheet (10 x 10) pinned at one corner, swinging down."""
    return sheet_shot("pendulum_sheet", 10, 10, 0.4, 0.4, plane="xz", pins=[0], frames=24)


def flag_wind(directory: Path) -> dict[str, Any]:
    """A 0.6 x 0.4 m flag (15 x 10) pinned at its top corners in gusty wind."""
    return sheet_shot("flag_wind", 15, 10, 0.6, 0.4, plane="xy", pins=[0, 14], frames=24, air_drag=0.4,
                      wind={"velocity": [1.5, 0.0, 3.0], "gust_amplitude": 0.5, "gust_frequency": 0.7},
                      material={"density": 0.2, "damping": 0.001})


def small_drape(directory: Path) -> dict[str, Any]:
    doc = drape_sphere(directory, n=24, frames=24)
    doc["name"] = "drape_sphere"
    return doc


def sleeve_swing(directory: Path) -> dict[str, Any]:
    doc = sleeve_shot(directory, frames=12, swing_frames=4)
    doc["name"] = "sleeve_swing"
    return doc


def box_pinch(directory: Path) -> dict[str, Any]:
    return box_pinch_shot(directory, n=12, after=2)


def twist(directory: Path) -> dict[str, Any]:
    return twist_shot(directory, n=10, frames=25, substeps=2)


def through_body(directory: Path) -> dict[str, Any]:
    doc = through_shot(frames=8, n=15)
    doc["name"] = "through_body"
    return doc


def self_tangled(directory: Path) -> dict[str, Any]:
    doc = two_sheets_shot(pushed=True, frames=8)
    doc["name"] = "self_tangled"
    doc["features"] = {"self_collision": True}
    return doc


def small_thin_limb(directory: Path) -> dict[str, Any]:
    return thin_limb(directory, n=16, frames=8)


def large_sheet(directory: Path) -> dict[str, Any]:
    """A 2 m sheet of 224 x 224 vertices pinned along its top edge, 3 frames (2 simulated)."""
    n = 224
    return sheet_shot("large_sheet", n, n, 2.0, 2.0, plane="xy", pins=list(range(n)), frames=3, air_drag=0.2)


SCENES: dict[str, Callable[[Path], dict[str, Any]]] = {
    "free_fall": free_fall,
    "hanging_strip": hanging_strip,
    "pendulum_sheet": pendulum_sheet,
    "flag_wind": flag_wind,
    "drape_sphere": small_drape,
    "sleeve_swing": sleeve_swing,
    "box_pinch": box_pinch,
    "twist": twist,
    "through_body": through_body,
    "self_tangled": self_tangled,
    "thin_limb": small_thin_limb,
    "large_sheet": large_sheet,
}

# Scenes judged against a formula instead of a stored converged run.
ANALYTIC = {"free_fall"}


def scene_folder(name: str) -> Path:
    return FOLDER / name
