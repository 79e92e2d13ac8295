"""Reports of a regression run: a Markdown summary, JUnit XML (one test case per scene, a
failure per exceeded threshold) and JSON."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

from regress.judge import SceneResult


def markdown(results: list[SceneResult]) -> str:
    failed = [r for r in results if not r.passed]
    lines = [f"# weft regress: {len(results) - len(failed)} of {len(results)} scenes passed", "",
             "| scene | verts | frames | result | pos. error RMS / max (mm) | inside | strain | "
             "CG it/substep | CCD cand/frame | passes/frame | s/frame |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        m = r.metrics

        def fmt(key: str, spec: str = ".3g") -> str:
            return format(m[key], spec) if m.get(key) is not None else "-"

        lines.append(f"| {r.scene} | {r.vertices} | {r.frames} | {'pass' if r.passed else '**FAIL**'} | "
                     f"{fmt('position_error_rms_mm')} / {fmt('position_error_max_mm')} | {fmt('inside_max', 'd')} | "
                     f"{fmt('max_strain')} | {fmt('cg_iterations_per_substep', '.1f')} | "
                     f"{fmt('ccd_candidates_per_frame', '.0f')} | {fmt('collision_iterations_per_frame', '.1f')} | "
                     f"{fmt('s_per_frame', '.3f')} |")
    if failed:
        lines += ["", "## Failures", ""]
        lines += [f"- {f.message}" for r in failed for f in r.failures]
    lines += ["", "Wall time (s/frame) is reported, never judged; the counts are judged against each scene's baseline."]
    return "\n".join(lines) + "\n"


def junit(results: list[SceneResult]) -> str:
    suite = ET.Element("testsuite", name="weft-regress", tests=str(len(results)),
                       failures=str(sum(not r.passed for r in results)))
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="regress", name=r.scene,
                             time=f"{r.metrics.get('s_per_frame', 0.0) * max(r.frames - 1, 0):.3f}")
        for f in r.failures:
            ET.SubElement(case, "failure", message=f.message, type=f.metric).text = f.message
    return ET.tostring(suite, encoding="unicode")


def write(results: list[SceneResult], directory: Path) -> dict[str, Path]:
    directory.mkdir(parents=True, exist_ok=True)
    paths = {"markdown": directory / "regress.md", "junit": directory / "regress.xml", "json": directory / "regress.json"}
    paths["markdown"].write_text(markdown(results))
    paths["junit"].write_text(junit(results))
    paths["json"].write_text(json.dumps({"passed": all(r.passed for r in results),
                                         "scenes": [r.as_dict() for r in results]}, indent=2) + "\n")
    return paths
