"""Another build of the solver in this process: `load_module(path)` makes the extension at `path`
the `weft._solver` every later import gets (`--module` of bench.contact, bench.limb_sweep and
the children of bench.module_ab)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def load_module(path: str) -> None:
    """Makes the extension at `path` the `weft._solver` every later import gets."""
    import importlib.util

    import weft

    spec = importlib.util.spec_from_file_location("weft._solver", path)
    if spec is None or spec.loader is None:
        raise SystemExit(f"--module: cannot load {path} as an extension module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    sys.modules["weft._solver"] = module
    weft._solver = module  # type: ignore[attr-defined]


def load_module_option(parser: argparse.ArgumentParser, path: str | None) -> None:
    """A bench's `--module PATH`: nothing when not given, a usage error naming the option when
    `path` is not a file, else `load_module(path)`."""
    if not path:
        return
    if not Path(path).is_file():
        parser.error(f"--module: {path} is not a file")
    load_module(path)


def add_module_option(parser: argparse.ArgumentParser) -> None:
    """A bench's `--module PATH` option (see `load_module_option`)."""
    parser.add_argument("--module", help="path of a weft._solver extension to run instead of the installed one")
