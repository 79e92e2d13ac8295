"""OpenMP's wait at a barrier: how long a thread spins before it sleeps, on an idle machine and on one
that other processes keep busy.

weft's threads meet at barriers many times per substep (CG iterations, the collision stage's
passes). A thread that arrives early spins `GOMP_SPINCOUNT` times before it sleeps in the
kernel: on an idle machine a short spin lets threads that arrive together pass at once, but when
another process wants the core, a spinning thread takes it from the very thread it waits for.
This bench runs contact scenes with several spin counts, first alone and then beside `--busy`
processes that each keep one core busy (plain Python loops, started and stopped here), each run
in a process of its own (libgomp reads the variable once, when it loads), the spin counts
alternating within each repeat, with weft's thread governor on (threads give way to the busy
processes after a frame: weft/thread_governor.py) or off (`WEFT_THREAD_GOVERNOR=off`):

    python -m bench.omp_wait [--scenes drape_sphere,articulated_dress,sleeve_swing]
        [--spins 0,1000,5000,10000,30000] [--busy 0,1] [--governor on,off] [--threads 2]
        [--repeat 2] [--json PATH]

It prints the median seconds per frame of every scene, load, spin count and governor setting,
and its ratio to weft's default (`weft.OPENMP_SPIN_COUNT`, governor on) under the same load:
below 1 is faster than the default.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

DEFAULT_SCENES = ("drape_sphere", "articulated_dress", "sleeve_swing")
DEFAULT_SPINS = (0, 1000, 5000, 10000, 30000)


def default_spin_count() -> int:
    """weft's own GOMP_SPINCOUNT (what a run gets unless the user sets the variable)."""
    import weft

    return weft.OPENMP_SPIN_COUNT


@contextmanager
def busy_processes(count: int) -> Iterator[list[subprocess.Popen[bytes]]]:
    """`count` processes that each keep one core busy until the block ends (then they are killed
    and reaped, also when the block raises)."""
    processes = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]
    try:
        if processes:
            time.sleep(1.0)  # let the scheduler see them
        yield processes
    finally:
        for process in processes:
            process.kill()
        for process in processes:
            process.wait()


def run_scene(scene: str, spin: int, threads: int, frames: int, governor: str = "on") -> dict[str, Any]:
    """One run of `scene` in a process of its own with GOMP_SPINCOUNT=spin and the thread
    governor `governor` ("on" or "off"): bench.module_ab's child figures (s_per_frame,
    cpu_per_frame, the step breakdown)."""
    env = dict(os.environ, GOMP_SPINCOUNT=str(spin), OMP_WAIT_POLICY="PASSIVE", WEFT_THREAD_GOVERNOR=governor)
    command = [sys.executable, "-m", "bench.module_ab", "--scene", scene, "--threads", str(threads),
               "--frames", str(frames), "--child", "installed", ""]
    done = subprocess.run(command, capture_output=True, text=True, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"{scene} with GOMP_SPINCOUNT={spin}: the run failed (exit {done.returncode}):\n"
                           f"{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def summarize(runs: list[dict[str, Any]], default_spin: int) -> list[dict[str, Any]]:
    """Per (scene, busy, spin, governor), in first-seen order: the runs' seconds per frame, their
    median and the median's ratio to the default spin count's with the governor on under the
    same scene and load (None where that was not run)."""
    groups: dict[tuple[str, int, int, str], list[float]] = {}
    for run in runs:
        key = (run["scene"], run["busy"], run["spin"], run.get("governor", "on"))
        groups.setdefault(key, []).append(run["s_per_frame"])
    rows = []
    for (scene, busy, spin, governor), seconds in groups.items():
        median = statistics.median(seconds)
        reference = groups.get((scene, busy, default_spin, "on"))
        ratio = median / statistics.median(reference) if reference else None
        rows.append({"scene": scene, "busy": busy, "spin": spin, "governor": governor, "s_per_frame": seconds,
                     "median": median, "ratio_to_default": ratio})
    return rows


def print_table(rows: list[dict[str, Any]], default_spin: int, threads: int, cores: int | None) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"OpenMP spin before sleeping: s/frame on {threads} thread(s), {cores} core(s); "
                        f"ratio = median / median at weft's default ({default_spin}, governor on) under the same load")
    for column in ("scene", "busy processes", "GOMP_SPINCOUNT", "governor", "s/frame (median)", "runs", "ratio"):
        table.add_column(column)
    for row in sorted(rows, key=lambda r: (r["scene"], r["busy"], r["spin"], r["governor"])):
        ratio = row["ratio_to_default"]
        table.add_row(row["scene"], str(row["busy"]), f"{row['spin']:,}" + (" (default)" if row["spin"] == default_spin
                                                                              else ""), row["governor"],
                      f"{row['median']:.4f}", " ".join(f"{s:.4f}" for s in row["s_per_frame"]),
                      "-" if ratio is None else f"{ratio:.2f}")
    Console(width=160).print(table)


def parse_ints(text: str, name: str, error: Any) -> list[int]:
    try:
        values = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        error(f"{name} {text!r}: expected comma-separated integers")
    if not values or any(v < 0 for v in values):
        error(f"{name} {text!r}: expected one or more integers >= 0")
    return values


def main(argv: list[str] | None = None) -> int:
    from bench.module_ab import sheet_side
    from scenes.contact import SCENES

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=",".join(DEFAULT_SCENES),
                        help="contact scenes or sheet:N (weft bench solver's N x N sheet), comma-separated")
    parser.add_argument("--spins", default=",".join(map(str, DEFAULT_SPINS)), help="GOMP_SPINCOUNT values")
    parser.add_argument("--busy", default="0,1", help="numbers of busy competing processes, one pass each")
    parser.add_argument("--governor", default="on", help="thread governor settings, comma-separated: on, off")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--frames", type=int, default=0, help="frames, the initial one included (default: per scene)")
    parser.add_argument("--repeat", type=int, default=2, help="runs per scene, load and spin count")
    parser.add_argument("--json", type=Path, help="also write every run's figures here")
    args = parser.parse_args(argv)
    scenes = [s for s in args.scenes.split(",") if s]
    unknown = [s for s in scenes if s not in SCENES and not sheet_side(s)]
    if not scenes or unknown:
        parser.error(f"--scenes: unknown scene(s) {unknown}; choose from {list(SCENES)} or sheet:N")
    spins = parse_ints(args.spins, "--spins", parser.error)
    busy_levels = parse_ints(args.busy, "--busy", parser.error)
    governors = [g for g in args.governor.split(",") if g]
    if not governors or any(g not in ("on", "off") for g in governors):
        parser.error(f"--governor {args.governor!r}: expected on, off or on,off")
    if args.threads < 1 or args.repeat < 1 or args.frames < 0 or args.frames == 1:
        parser.error("--threads and --repeat must be at least 1, --frames 0 (per scene) or at least 2")
    default_spin = default_spin_count()
    runs: list[dict[str, Any]] = []
    for busy in busy_levels:
        with busy_processes(busy):
            for repeat in range(args.repeat):
                for scene in scenes:
                    for spin in spins:
                        for governor in governors:
                            figures = run_scene(scene, spin, args.threads, args.frames, governor)
                            runs.append({"scene": scene, "busy": busy, "spin": spin, "governor": governor,
                                         "repeat": repeat, **figures})
                            print(f"{scene} busy={busy} spin={spin} governor={governor} run {repeat + 1}: "
                                  f"{figures['s_per_frame']:.4f} s/frame", file=sys.stderr)
    rows = summarize(runs, default_spin)
    print_table(rows, default_spin, args.threads, os.cpu_count())
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"threads": args.threads, "cpus": os.cpu_count(), "default_spin": default_spin,
                                         "rows": rows, "runs": runs}, indent=1))
        print(f"wrote {args.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
