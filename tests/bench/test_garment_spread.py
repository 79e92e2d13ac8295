"""bench.garment_spread: the walking skirt and its thinner copies, one row each, and its
argument checks."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from bench.garment_spread import SPREAD, factors, main


def test_the_factors_start_unperturbed_and_stay_thinner() -> None:
    assert factors(0) == [1.0]
    spread = factors(4)
    assert spread[0] == 1.0 and len(spread) == 5
    assert spread[1] == pytest.approx(1.0 - SPREAD)
    assert all(a < b < 1.0 for a, b in zip(spread[1:], spread[2:]))


def test_every_copy_runs_and_is_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "spread.json"
    assert main(["--copies", "1", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())["copies"]
    assert [row["factor"] for row in rows] == pytest.approx([1.0, 1.0 - SPREAD])
    for row in rows:
        assert row["failure"] is None
        assert math.isfinite(row["max_strain"]) and row["max_strain"] >= 1.0
        assert row["frames_with_inside"] == 0 and row["inside_max"] == 0  # as the garment test asks
        assert row["seconds_per_frame"] > 0.0
    printed = capsys.readouterr().out
    assert "walking skirt, 2 runs" in printed
    assert f"{rows[0]['max_strain']:.3f}" in printed


@pytest.mark.parametrize("argv", [["--copies", "-1"], ["--threads", "0"]])
def test_bad_arguments_are_refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert argv[0] in capsys.readouterr().err
