"""The stability map's cells: implicit steps stay finite on the stiffest cloth at the longest
step and under a body driven through the sheet at 30 m/s; the default cell is plain 'ok'."""

from __future__ import annotations

from pathlib import Path

from regress.stability import classify


def test_default_cell_is_ok(tmp_path: Path) -> None:
    cell = classify("stretch", 2000.0, 4, tmp_path)
    assert cell.status == "ok" and cell.max_strain is not None and cell.max_strain < 1.1


def test_stiff_cloth_at_one_step_per_frame_stays_finite_and_bounded(tmp_path: Path) -> None:
    cell = classify("stretch", 2e6, 1, tmp_path)  # stiffness ratio 1e5 over the softest, h = 1/24 s
    assert cell.status == "ok", cell


def test_a_body_at_30_m_s_never_lets_a_nan_out(tmp_path: Path) -> None:
    cell = classify("body_speed", 30.0, 1, tmp_path)
    assert cell.status != "NaN" and cell.max_speed is not None
    assert cell.status in {"ok", "strain", "fast"} or cell.status.startswith("failed@")
