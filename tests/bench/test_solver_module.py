"""`--module PATH` of the benchmarks that run another build of the solver in their own process
(bench.solver_module.load_module): a path that is not there is named, never a traceback."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from bench import contact, garment_spread, limb_sweep


@pytest.mark.parametrize(("main", "argv"), [(limb_sweep.main, ["--frames", "2"]),
                                            (contact.main, ["--scenes", "sleeve_swing"]),
                                            (garment_spread.main, ["--copies", "0"])],
                         ids=["limb_sweep", "contact", "garment_spread"])
def test_a_module_that_is_not_there_is_named(main: Callable[[list[str]], int], argv: list[str], tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "missing.so"
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--module", str(missing)])
    assert exc.value.code == 2
    assert f"--module: {missing} is not a file" in capsys.readouterr().err

