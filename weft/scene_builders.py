"""DEPRECATED, remove at merge (issue 11): the scene builders moved to ``scenes.builders``.

Kept only so that branches written against the old name (tests/service, bench/service_bench.py)
keep working until they import ``scenes.builders``; the import-linter contract that keeps
``weft`` from importing ``scenes`` ignores this one module.
"""

from scenes.builders import grid_sheet, inline_mesh, sheet_shot  # noqa: F401

__all__ = ["grid_sheet", "inline_mesh", "sheet_shot"]
