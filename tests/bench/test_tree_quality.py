"""`python -m bench.tree_quality`: the cloth tree's refitted cost against a fresh build's, on a
short run of the sleeve; clear errors for bad input."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.tree_quality import main, tree_drift


def test_the_refitted_tree_stays_close_to_a_fresh_build_on_the_sleeve() -> None:
    rows = tree_drift("sleeve_swing", frames=9, every=4, threads=1)
    assert [r["frame"] for r in rows] == [0, 4, 8]
    assert rows[0]["ratio"] == 1.0  # built from the first frame's positions
    assert all(0.8 < r["ratio"] < 1.25 for r in rows)
    assert rows[-1]["refitted"] != rows[0]["refitted"]  # the sleeve moved


def test_the_command_writes_its_rows(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "tree.json"
    args = ["--scenes", "sleeve_swing", "--frames", "3", "--every", "2", "--threads", "1", "--json", str(out)]
    assert main(args) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [r["frame"] for r in rows] == [0, 2]
    assert "largest ratio" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["--scenes", "nope"], "--scenes 'nope'"),
    (["--every", "0"], "--every 0"),
    (["--frames", "1"], "--frames 1"),
    (["--threads", "0"], "--threads 0"),
])
def test_bad_arguments_are_named(args: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(args)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
