"""Another build of the solver in this process: `load_module(path)` makes the extension at `path`
the `weft._solver` every later import gets (`--module` of bench.contact, bench.limb_sweep and
the children of bench.module_ab)."""

from __future__ import annotations

import sys


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
