"""`python -m bench.regress_spread` on the small thin limb: one copy each side of the unperturbed
run, the judged figures of each, and clear errors for what it cannot run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.regress_spread import main


def test_the_thin_limb_over_perturbed_copies(tmp_path: Path) -> None:
    out = tmp_path / "spread.json"
    assert main(["--scenes", "thin_limb", "--copies", "2", "--threads", "1", "--json", str(out)]) == 0
    copies = json.loads(out.read_text())["thin_limb"]
    factors = [c["factor"] for c in copies]
    assert factors == sorted(factors) and len(factors) == 3 and 1.0 in factors
    assert factors[0] < 1.0 < factors[-1]
    for c in copies:
        assert not c["failed"]
        assert c["max_mm"] >= c["rms_mm"] > 0.0
        assert c["strain"] >= 1.0
    # The perturbation moves the chaotic scene: the copies' errors differ.
    assert len({round(c["rms_mm"], 6) for c in copies}) > 1


@pytest.mark.parametrize("argv, message", [
    (["--scenes", "no_such_scene"], "unknown regression scene"),
    (["--scenes", "free_fall"], "analytic"),
    (["--copies", "0"], "--copies"),
])
def test_bad_arguments_name_the_problem(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
