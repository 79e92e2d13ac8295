"""Body animation timing (issue 18): samples at their own rate, shifted by frame_offset, read at
the shot's frame times with linear interpolation; an animation that does not cover the shot is
refused, naming the field and the frames it covers."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scenes.builders import inline_mesh, sheet_shot
from weft.shot import ShotError, parse_shot
from weft.solver_setup import resolve_scene

TRIANGLE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def shot_with_body(tmp_path: Path, samples: np.ndarray, **timing: Any) -> dict[str, Any]:
    np.save(tmp_path / "body.npy", samples)
    shot = sheet_shot("timed", 3, 3, 0.2, 0.2, frames=9)  # frames 1-9 at 24 fps
    shot["bodies"] = [{"name": "prop", "mesh": inline_mesh(TRIANGLE, np.array([[0, 1, 2]])),
                       "animation": {"path": "body.npy"}, "collide": False, **timing}]
    return shot


def moving(times: np.ndarray) -> np.ndarray:
    """The triangle moving along x at 1 m per unit of `times`."""
    return TRIANGLE[None] + times[:, None, None] * np.array([1.0, 0.0, 0.0])


def body_frames(tmp_path: Path, samples: np.ndarray, **timing: Any) -> np.ndarray:
    scene = resolve_scene(parse_shot(shot_with_body(tmp_path, samples, **timing)), tmp_path)
    return np.asarray(scene.bodies[0].frames)


def test_one_sample_per_frame_is_used_as_is(tmp_path: Path) -> None:
    samples = np.random.default_rng(3).normal(size=(9, 3, 3))
    assert np.array_equal(body_frames(tmp_path, samples), samples)


def test_samples_at_four_times_the_frame_rate_are_read_at_the_frame_times(tmp_path: Path) -> None:
    samples = moving(np.arange(33) / 96.0)  # 96 samples per second, 4 per 24 fps frame
    frames = body_frames(tmp_path, samples, animation_fps=96.0)
    assert np.array_equal(frames, samples[::4])


def test_a_shifted_slower_animation_is_interpolated_linearly(tmp_path: Path) -> None:
    # 12 samples per second (every other frame), sample 0 playing 1.5 frames before the shot's first.
    samples = moving(np.arange(8) / 12.0)
    frames = body_frames(tmp_path, samples, animation_fps=12.0, frame_offset=-1.5)
    expected_seconds = (np.arange(9) + 1.5) / 24.0  # shot frame i plays animation time (i + 1.5) / 24 s
    assert np.allclose(frames, moving(expected_seconds), rtol=0, atol=1e-12)


@pytest.mark.parametrize(("count", "timing", "covers"), [
    (8, {}, "frames 1-8"),
    (9, {"frame_offset": 0.5}, "frames 1.5-9.5"),
    (20, {"animation_fps": 48.0, "frame_offset": 0.25}, "frames 1.25-10.75"),
])
def test_an_animation_that_does_not_cover_the_shot_is_refused(tmp_path: Path, count: int, timing: dict[str, float],
                                                              covers: str) -> None:
    with pytest.raises(ShotError) as error:
        body_frames(tmp_path, moving(np.arange(count, dtype=float)), **timing)
    assert error.value.field == "bodies[0].animation" and covers in str(error.value) and "[1, 9]" in str(error.value)


def test_bad_timing_fields_name_themselves(tmp_path: Path) -> None:
    for timing, field in (({"animation_fps": 0}, "animation_fps"), ({"frame_offset": float("nan")}, "frame_offset")):
        with pytest.raises(Exception) as error:
            parse_shot(shot_with_body(tmp_path, moving(np.arange(9.0)), **timing))
        assert f"bodies[0].{field}" in str(error.value), str(error.value)
