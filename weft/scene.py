"""DEPRECATED, remove at merge (issue 11): ``weft.scene`` split into ``weft.shot``,
``weft.assets`` and ``weft.solver_setup``.

Re-exports exactly the names server/app.py and workers/worker.py import on the concurrent
service branch, so that branch keeps working until it imports the new modules.
"""

from weft.assets import asset_paths
from weft.shot import ShotError, ShotValidationError, parse_shot
from weft.solver_setup import resolve_scene

__all__ = ["ShotError", "ShotValidationError", "asset_paths", "parse_shot", "resolve_scene"]
