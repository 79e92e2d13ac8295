"""The `weft regress` driver: which scenes, where they run (a given service, a local stack it
starts, or this process), the verdicts and the reports."""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

from regress import references
from regress.judge import SceneResult, judge
from regress.report import markdown, write
from regress.runs import Run, resolve, run_here, write_shot
from scenes.regression import SCENES


def run_scenes(names: list[str], where: str, server: str | None, workers: int, threads: int,
               log: Callable[[str], None]) -> list[SceneResult]:
    """where: 'service' (server given, or a local stack started here) or 'local' (this process)."""
    with tempfile.TemporaryDirectory(prefix="weft-regress-") as tmp:
        work = Path(tmp)
        shots = {name: write_shot(name, work / name) for name in names}
        scenes = {name: resolve(path) for name, path in shots.items()}
        runs: dict[str, Run]
        if where == "local":
            runs = {}
            for name in names:
                log(f"running {name} here")
                runs[name] = run_here(scenes[name], threads)
        elif server:
            from regress.service import run_through_service

            runs = run_through_service(server, names, shots, work)
        else:
            from regress.service import run_through_service
            from server.stack import Stack

            log(f"starting a local stack (Redis, API, {workers} workers)")
            with Stack(work / "service", workers=workers) as stack:
                runs = run_through_service(stack.url, names, shots, work)
        results = []
        for name in names:
            log(f"judging {name}")
            results.append(judge(name, scenes[name], runs[name], threads))
        return results


def main(names: list[str], where: str, server: str | None, workers: int, threads: int, out: Path,
         log: Callable[[str], None]) -> tuple[bool, str, dict[str, Path]]:
    results = run_scenes(names, where, server, workers, threads, log)
    paths = write(results, out)
    return all(r.passed for r in results), markdown(results), paths


def update_references(names: list[str], threads: int, log: Callable[[str], None]) -> str:
    """Writes every scene's reference, then judges a default run against it (the figures to set
    thresholds by); returns that summary."""
    lines = []
    with tempfile.TemporaryDirectory(prefix="weft-references-") as tmp:
        for name in names:
            log(f"reference of {name}")
            meta, scene, default_run = references.update(name, Path(tmp) / name, threads)
            result = judge(name, scene, default_run, threads)
            m = result.metrics
            lines.append(f"{name}: reference {meta['reference'] if isinstance(meta['reference'], str) else 'converged'}"
                         f", default run error RMS {m['position_error_rms_mm']:.3g} mm, max "
                         f"{m['position_error_max_mm']:.3g} mm, counts {meta['baseline_counts']}"
                         f"{'' if result.passed else ' FAILS: ' + '; '.join(f.message for f in result.failures)}")
    return "\n".join(lines)


def all_scenes() -> list[str]:
    return list(SCENES)
