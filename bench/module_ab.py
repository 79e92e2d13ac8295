"""Module against module: one contact scene run by two or more builds of the solver.

A change to the solver is measured against the build before it on the same scene, in the same
hour, runs alternating, each in a process of its own (two builds of `weft._solver` cannot share
one process). Each run reports wall and CPU seconds per frame, its costliest frame (and that
over the run's median frame: issue 12's bound on a frame's cost) and weft's step breakdown; with
`--threads 1` the CPU time is the work itself, which a shared machine's neighbours move far less
than the wall time. `--save-positions` also says whether the runs' positions are bitwise equal
(a change meant to leave them alone).

Build a module elsewhere (for instance a copy of `.venv/lib/python3.11/site-packages/weft/` from
before the change, or `cmake -S solver_cpp -B /tmp/other -DWEFT_BUILD_PYTHON=ON`), then:

    python -m bench.module_ab --scene drape_sphere --module before=/tmp/a.so --module after=/tmp/b.so \
        --threads 1 --repeat 2 [--frames 48] [--save-positions] [--json PATH]

`--scene` also takes a shot file (`scenes/generated/demo_flag.yaml`, after `python scenes/generate.py`),
or `sheet:N`: `weft bench solver`'s N x N sheet (pinned at two corners, in wind; 3 frames unless
`--frames` says otherwise), for the linear system at a size of its own.

`--module NAME=PATH` may name the installed build: `--module now=installed`.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as bench/contact.py: shared 2-core machines

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

from bench.solver_module import load_module  # noqa: E402

SHOT_SUFFIXES = (".yaml", ".yml", ".json")  # --scene given as a shot file
SHEET_PREFIX = "sheet:"  # --scene sheet:N, `weft bench solver`'s N x N sheet
SHEET_FRAMES = 3


def sheet_side(scene: str) -> int | None:
    """N of a `sheet:N` scene (None for other scenes; 0 when N is not an integer of at least 2)."""
    if not scene.startswith(SHEET_PREFIX):
        return None
    text = scene[len(SHEET_PREFIX):]
    return int(text) if text.isdigit() and int(text) >= 2 else 0
COLUMNS = ("build_seconds_per_frame", "solve_seconds_per_frame", "setup_seconds_per_frame",
           "collision_seconds_per_frame", "collision_broad_phase_seconds_per_frame",
           "collision_proximity_seconds_per_frame", "gia_seconds_per_frame", "ccd_candidates_per_frame",
           "broad_phase_pairs_per_frame", "cg_iterations_per_substep")


def child(scene_name: str, module: str, frames: int, threads: int, positions: str | None) -> dict[str, Any]:
    """One run in this process: the scene's figures as a dict (printed as JSON by main)."""
    if module != "installed":
        load_module(module)
    import numpy as np

    from bench.contact import DEFAULT_FRAMES, build_scene, run_weft, weft_breakdown

    with tempfile.TemporaryDirectory() as directory:
        side = sheet_side(scene_name)
        if side:
            from bench.solver_bench import sheet_document
            from regress.runs import resolve

            frames = frames or SHEET_FRAMES
            document = sheet_document(side)
            document["frame_range"] = [1, frames]
            path = Path(directory) / f"sheet_{side}.json"
            path.write_text(json.dumps(document))
            scene = resolve(path)
        elif Path(scene_name).suffix in SHOT_SUFFIXES:
            from regress.runs import resolve

            scene = resolve(Path(scene_name))
            first, last = scene.shot.frame_range
            frames = frames or last - first + 1
        else:
            frames = frames or DEFAULT_FRAMES[scene_name]
            scene = build_scene(scene_name, Path(directory), frames)
        cpu = time.process_time()
        result = run_weft(scene, frames, threads)
        cpu = time.process_time() - cpu
    if positions:
        np.save(positions, result["positions"])
    seconds = result["frame_seconds"]
    simulated = max(len(seconds), 1)
    return {"s_per_frame": float(np.mean(seconds)) if len(seconds) else float("nan"),
            "median_frame": float(np.median(seconds)) if len(seconds) else float("nan"),
            "first_frame": float(seconds[0]) if len(seconds) else float("nan"),
            "max_frame": float(np.max(seconds)) if len(seconds) else float("nan"),
            "worst_over_median_frame": float(np.max(seconds) / np.median(seconds)) if len(seconds) else float("nan"),
            "cpu_per_frame": cpu / simulated, "failure": result["failure"],
            **{k: v for k, v in weft_breakdown(result["telemetry"]).items() if k in COLUMNS}}


def parse_modules(specs: list[str], error: Any) -> list[tuple[str, str]]:
    """(name, path) per --module NAME=PATH; `error` (the parser's) for what cannot be run."""
    modules: list[tuple[str, str]] = []
    for spec in specs:
        name, sep, path = spec.partition("=")
        if not sep or not name or not path:
            error(f"--module {spec!r}: expected NAME=PATH (PATH a built weft/_solver*.so, or 'installed')")
        if path != "installed" and not Path(path).is_file():
            error(f"--module {name}: no such file: {path}")
        if name in (n for n, _ in modules):
            error(f"--module {name}: named twice")
        modules.append((name, path))
    if len(modules) < 2:
        error("--module: give at least two builds to compare")
    return modules


def main(argv: list[str] | None = None) -> int:
    from scenes.contact import SCENES

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default="drape_sphere",
                        help="a contact scene (" + ", ".join(SCENES) + "), a shot file (.yaml, .json) or sheet:N")
    parser.add_argument("--module", action="append", default=[], metavar="NAME=PATH",
                        help="a build of weft._solver to run ('installed' for the one in use); two or more")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--frames", type=int, default=0, help="frames, the initial one included (default: per scene)")
    parser.add_argument("--repeat", type=int, default=2, help="runs per module, the modules alternating")
    parser.add_argument("--save-positions", action="store_true", help="compare the runs' positions bit for bit")
    parser.add_argument("--json", type=Path, help="also write every run's figures here")
    parser.add_argument("--child", nargs=2, metavar=("MODULE", "POSITIONS"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    side = sheet_side(args.scene)
    if side is not None:
        if not side:
            parser.error(f"--scene {args.scene!r}: expected sheet:N with N an integer of at least 2")
    elif Path(args.scene).suffix in SHOT_SUFFIXES:
        if not Path(args.scene).is_file():
            parser.error(f"--scene {args.scene}: no such shot file")
    elif args.scene not in SCENES:
        parser.error(f"--scene {args.scene!r}: not a contact scene ({', '.join(SCENES)}) nor a shot file")
    if args.threads < 1 or args.repeat < 1 or args.frames < 0 or args.frames == 1:
        parser.error("--threads and --repeat must be at least 1, --frames 0 (per scene) or at least 2")
    if args.child:
        module, positions = args.child
        print(json.dumps(child(args.scene, module, args.frames, args.threads, positions or None)))
        return 0
    modules = parse_modules(args.module, parser.error)

    import numpy as np
    from rich.console import Console
    from rich.table import Table

    runs: dict[str, list[dict[str, Any]]] = {name: [] for name, _ in modules}
    with tempfile.TemporaryDirectory() as directory:
        for repeat in range(args.repeat):
            for name, path in modules:
                positions = str(Path(directory) / f"{name}_{repeat}.npy") if args.save_positions else ""
                command = [sys.executable, "-m", "bench.module_ab", "--scene", args.scene, "--threads",
                           str(args.threads), "--frames", str(args.frames), "--child", path, positions]
                done = subprocess.run(command, capture_output=True, text=True)
                if done.returncode != 0:
                    print(done.stderr, file=sys.stderr)
                    raise SystemExit(f"module {name} ({path}): the run failed (exit {done.returncode})")
                runs[name].append(json.loads(done.stdout.strip().splitlines()[-1]))
                print(f"{args.scene} {name} run {repeat + 1}: {runs[name][-1]['s_per_frame']:.4f} s/frame",
                      file=sys.stderr)
        bitwise: dict[str, bool] = {}
        if args.save_positions:
            first = np.load(Path(directory) / f"{modules[0][0]}_0.npy")
            for name, _ in modules:
                bitwise[name] = all(np.array_equal(first, np.load(Path(directory) / f"{name}_{r}.npy"))
                                    for r in range(args.repeat))

    table = Table(title=f"{args.scene}, {args.threads} thread(s), {args.repeat} run(s) per module, alternating "
                        "(per simulated frame; CPU: the process's CPU seconds)")
    for column in ("module", "s/frame", "worst frame (x median)", "CPU s/frame", "build", "solve (setup)",
                   "collision (broad, prox)", "GIA", "CCD cand", "CG it/substep") + (
                       ("positions = first module's",) if bitwise else ()):
        table.add_column(column)
    for name, _ in modules:
        r = runs[name]
        def span(key: str, digits: int = 4) -> str:
            values = [x[key] for x in r]
            return f"{min(values):.{digits}f}" + (f"-{max(values):.{digits}f}" if len(values) > 1 else "")
        table.add_row(name, span("s_per_frame"), f"{span('max_frame')} ({span('worst_over_median_frame', 1)})",
                      span("cpu_per_frame"), span("build_seconds_per_frame"),
                      f"{span('solve_seconds_per_frame')} ({span('setup_seconds_per_frame')})",
                      f"{span('collision_seconds_per_frame')} ({span('collision_broad_phase_seconds_per_frame')}, "
                      f"{span('collision_proximity_seconds_per_frame')})", span("gia_seconds_per_frame"),
                      span("ccd_candidates_per_frame", 0), span("cg_iterations_per_substep", 1),
                      *((("yes" if bitwise[name] else "no"),) if bitwise else ()))
    Console(width=200).print(table)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"scene": args.scene, "threads": args.threads, "repeat": args.repeat,
                                         "modules": dict(modules), "runs": runs, "bitwise": bitwise}, indent=1))
        print(f"wrote {args.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
