"""Layering of the C++ solver (solver_cpp/): the folders of src/weft/ are the stages of the step,
and a file may include only files of its own folder or of a lower layer. No build needed: the
`#include "weft/..."` lines are parsed.

Layers, lowest first (folders in one layer may not include each other):
    common < mesh, geometry < forces < linear_system < bodies < collision < gia
    < step (src/weft/*: integrator, collision_system) < python, bench
The core (src/weft) never includes the Python bindings or the benchmark support; no include
cycle between files (a header and its .cpp count as one unit); no source file over 600 lines.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "solver_cpp"
MAX_LINES = 600
LAYERS: list[set[str]] = [
    {"common"},
    {"mesh", "geometry"},
    {"forces"},
    {"linear_system"},
    {"bodies"},
    {"collision"},
    {"gia"},
    {"step"},
    {"python", "bench"},
]
RANK = {folder: rank for rank, folders in enumerate(LAYERS) for folder in folders}
INCLUDE = re.compile(r'^\s*#\s*include\s+"(weft/[^"]+)"', re.MULTILINE)
QUOTED = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.MULTILINE)


def folder_of(path: str) -> str:
    """Layer folder of a path relative to solver_cpp/ (src/weft/<stage>/f, src/weft/f, python/f, bench/f)."""
    parts = Path(path).parts
    if parts[0] == "src":
        return parts[2] if len(parts) > 3 else "step"
    return parts[0]


def unit_of(path: str) -> str:
    """A header and its implementation are one unit for cycles."""
    return str(Path(path).with_suffix(""))


def source_files(root: Path) -> list[Path]:
    files = []
    for sub in ("src/weft", "python", "bench"):
        files += [p for p in sorted((root / sub).rglob("*")) if p.suffix in (".h", ".cpp")]
    return files


def include_graph(root: Path) -> dict[str, list[str]]:
    """File (relative to root) -> the weft files it includes (relative to root)."""
    graph = {}
    for p in source_files(root):
        graph[str(p.relative_to(root))] = ["src/" + inc for inc in INCLUDE.findall(p.read_text())]
    return graph


def layering_violations(root: Path) -> list[str]:
    graph = include_graph(root)
    problems = []
    for p in source_files(root):
        rel = str(p.relative_to(root))
        if folder_of(rel) not in ("python", "bench"):  # the core includes only "weft/..." headers
            problems += [f"{rel}: core includes {inc} (not weft/...)" for inc in QUOTED.findall(p.read_text())
                         if not inc.startswith("weft/")]
    for f, includes in graph.items():
        for inc in includes:
            if not (root / inc).is_file():
                problems.append(f"{f}: includes missing file {inc}")
                continue
            src, dst = folder_of(f), folder_of(inc)
            if src not in RANK or dst not in RANK:
                problems.append(f"{f} -> {inc}: folder not in the declared layers")
            elif dst in ("python", "bench") and src != dst:
                problems.append(f"{f} -> {inc}: only python/bench may include {dst}")
            elif src != dst and RANK[dst] >= RANK[src]:
                problems.append(f"{f} ({src}) -> {inc} ({dst}): {dst} is not below {src}")
    # Cycles between units (header + .cpp), depth-first.
    units: dict[str, set[str]] = {}
    for f, includes in graph.items():
        units.setdefault(unit_of(f), set()).update(unit_of(i) for i in includes if unit_of(i) != unit_of(f))
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(u: str) -> None:
        state[u] = 1
        stack.append(u)
        for w in sorted(units.get(u, ())):
            if state.get(w) == 1:
                problems.append("include cycle: " + " -> ".join(stack[stack.index(w):] + [w]))
            elif w not in state:
                visit(w)
        stack.pop()
        state[u] = 2

    for u in sorted(units):
        if u not in state:
            visit(u)
    return problems


def long_files(root: Path) -> list[str]:
    files = [p for p in sorted(root.rglob("*")) if p.suffix in (".h", ".cpp") and "build" not in p.parts]
    return [f"{p.relative_to(root)}: {n} lines" for p in files if (n := len(p.read_text().splitlines())) > MAX_LINES]


def test_the_core_tree_is_layered_and_acyclic():
    assert (ROOT / "src/weft").is_dir()
    problems = layering_violations(ROOT)
    assert not problems, "\n".join(problems)


def test_no_source_file_over_600_lines():
    assert not long_files(ROOT), "\n".join(long_files(ROOT))


def _write(root: Path, rel: str, *includes: str) -> None:
    p = root / rel
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text("".join(f'#include "{i}"\n' for i in includes))


@pytest.mark.parametrize(
    "files, expected",
    [
        ({"src/weft/common/a.h": [], "src/weft/gia/b.h": ["weft/common/a.h"]}, None),
        ({"src/weft/common/a.h": ["weft/gia/b.h"], "src/weft/gia/b.h": []}, "is not below"),
        ({"src/weft/mesh/a.h": ["weft/geometry/b.h"], "src/weft/geometry/b.h": []}, "is not below"),
        ({"src/weft/gia/a.h": ["weft/gia/b.h"], "src/weft/gia/b.cpp": ["weft/gia/a.h"], "src/weft/gia/b.h": []},
         "include cycle"),
        ({"src/weft/integrator.h": [], "bench/x.h": ["weft/integrator.h"], "src/weft/gia/a.cpp": ["weft/x.h"]},
         "missing file"),
        ({"src/weft/gia/a.cpp": ["bench_support.h"]}, "core includes"),
        ({"src/weft/newstage/a.h": [], "src/weft/gia/b.h": ["weft/newstage/a.h"]}, "not in the declared layers"),
    ],
)
def test_the_checker_catches_violations(tmp_path, files, expected):
    for rel, includes in files.items():
        _write(tmp_path, rel, *includes)
    problems = layering_violations(tmp_path)
    if expected is None:
        assert not problems
    else:
        assert any(expected in p for p in problems), problems


def test_the_checker_catches_long_files(tmp_path):
    (tmp_path / "src/weft/common").mkdir(parents=True)
    (tmp_path / "src/weft/common/big.cpp").write_text("//\n" * (MAX_LINES + 1))
    assert long_files(tmp_path)
