"""Small helpers the service benchmarks share."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def percentiles(values: list[float]) -> dict[str, float]:
    """n, p50, p90, p99 and max of a sample (nearest rank)."""
    ordered = sorted(values)

    def pick(q: float) -> float:
        return ordered[min(len(ordered) - 1, int(q * len(ordered)))]

    return {"n": len(ordered), "p50": pick(0.5), "p90": pick(0.9), "p99": pick(0.99), "max": ordered[-1]}


def write_json(path: Path | None, results: dict[str, Any]) -> None:
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(results, indent=2))
