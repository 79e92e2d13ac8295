"""`python -m bench.tolerance` end to end on the contact-free scene at a few frames: its JSON
holds what the table prints, and the error grows as the tolerance loosens."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.tolerance import main


def test_looser_tolerance_costs_fewer_iterations_and_more_error(tmp_path: Path) -> None:
    out = tmp_path / "tolerance.json"
    # 1e-4, not 1e-5, as the tight run: on this smooth swing a 1e-5 solve's error (about 3e-5 mm
    # over 4 frames) is already at the floor, float32 rounding, which moves with the last bits
    # of the preconditioner; 1e-4's (about 4e-4 mm) is ten times above it.
    assert main(["--scenes", "hanging_sheet", "--frames", "4", "--tolerances", "1e-2,1e-4", "--threads", "1",
                 "--json", str(out)]) == 0
    result = json.loads(out.read_text())["hanging_sheet"]
    loose, tight = result["rows"]
    assert (loose["tolerance"], tight["tolerance"]) == (1e-2, 1e-4)
    assert loose["cg_iterations_per_substep"] < tight["cg_iterations_per_substep"]
    assert loose["rms_error_mm"] > tight["rms_error_mm"] >= 0.0
    assert loose["max_error_mm"] >= loose["rms_error_mm"] > 0.0
    # The floor (1e-7 against 1e-8) sits below the 1e-4 run's error on smooth dynamics.
    assert result["floor"]["rms_error_mm"] <= tight["rms_error_mm"]


@pytest.mark.parametrize("argv, message", [
    (["--scenes", "nope"], "unknown scene"),
    (["--tolerances", "1e-3,abc"], "--tolerances"),
    (["--tolerances", "1e-3", "--reference", "1e-2"], "reference below"),
])
def test_bad_arguments_exit_with_a_message(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
