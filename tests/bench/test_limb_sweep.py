"""bench.limb_sweep: the thin limb over its variants, one row each, and its argument checks."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.limb_sweep import VARIANTS, main


def test_every_variant_runs_and_is_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "sweep.json"
    assert main(["--frames", "3", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert [row["variant"] for row in rows] == VARIANTS
    for row in rows:
        assert row["failure"] is None
        assert len(row["strain_per_frame"]) == 2
        assert row["max_strain"] == max(row["strain_per_frame"])
        assert row["last_strain"] == row["strain_per_frame"][-1]
        # The limb starts 0.25 m behind the sheet: at 4 m/s at most it has not reached it after
        # one frame, and the sheet hangs at its rest lengths.
        assert abs(row["strain_per_frame"][0] - 1.0) < 0.02, row
        assert row["seconds_per_frame"] > 0.0
    assert "thin limb variants" in capsys.readouterr().out


def test_the_cg_tolerance_reaches_every_variant(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "sweep.json"
    assert main(["--frames", "2", "--cg-tolerance", "1e-5", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert [row["cg_tolerance"] for row in rows] == [1e-5] * len(VARIANTS)
    assert "CG tolerance 1e-05" in capsys.readouterr().out


@pytest.mark.parametrize("argv", [["--frames", "1"], ["--threads", "0"], ["--cg-tolerance", "0"],
                                  ["--cg-tolerance", "1.5"]])
def test_bad_arguments_are_refused(argv: list[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
