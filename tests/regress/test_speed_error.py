"""`weft report speed-error`: the Pareto front and the cheapest setting are chosen right, and a
real sweep on free fall shows backward Euler's first-order error in the time step."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from regress.speed_error import SWEEP, Point, cheapest_within, mark_pareto, overrides_for

ROOT = Path(__file__).resolve().parents[2]


def point(label: str, seconds: float | None, error: float | None) -> Point:
    return Point("s", label, 4, {}, seconds, error, error, None if seconds is not None else "failed")


def test_pareto_front_and_cheapest_within() -> None:
    points = [point("slow exact", 1.0, 0.1), point("fast rough", 0.1, 5.0), point("dominated", 1.2, 0.2),
              point("middle", 0.5, 1.0), point("tie slower", 0.6, 1.0), point("failed", None, None)]
    mark_pareto(points)
    assert [p.label for p in points if p.pareto] == ["slow exact", "fast rough", "middle"]
    assert cheapest_within(points, 1.0).label == "middle"  # type: ignore[union-attr]
    assert cheapest_within(points, 0.15).label == "slow exact"  # type: ignore[union-attr]
    assert cheapest_within(points, 0.01) is None


def test_substep_multiples_round_and_stay_positive() -> None:
    assert overrides_for(4, {"substeps": 0.25, "solver": {"cg_tolerance": 1e-2}}) == {
        "substeps": 1, "solver": {"cg_tolerance": 1e-2}}
    assert overrides_for(3, {"substeps": 0.25}) == {"substeps": 1}
    assert overrides_for(4, {}) == {}


def test_free_fall_sweep_through_the_cli(tmp_path: Path) -> None:
    weft = str(Path(sys.executable).parent / "weft")
    result = subprocess.run([weft, "report", "speed-error", "free_fall", "--repeats", "1", "--within", "30", "-o",
                             str(tmp_path)], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "free_fall: cheapest within 30 mm RMS:" in result.stdout
    report = json.loads((tmp_path / "speed_error.json").read_text())
    points = {p["label"]: p for p in report["scenes"]["free_fall"]["points"]}
    assert list(points) == [label for label, _ in SWEEP]
    # Backward Euler lags free fall by g h t / 2: half the step, half the error (to a few %).
    ratio = points["substeps x0.5"]["error_rms_mm"] / points["defaults"]["error_rms_mm"]
    assert 1.9 < ratio < 2.1, ratio
    assert points["substeps x2"]["error_rms_mm"] < points["defaults"]["error_rms_mm"]
    assert (tmp_path / "speed_error_free_fall.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = subprocess.run([weft, "report", "speed-error", "nowhere"], cwd=ROOT, capture_output=True, text=True,
                         timeout=60)
    assert bad.returncode == 2 and "unknown scene(s) nowhere" in bad.stderr
