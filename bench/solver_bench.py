"""`weft bench solver`: the fast linear system against the reference path, shaped like Table 1
of the seed talk (Eberle 2018), on square sheets of about 10k, 40k, 160k and 640k vertices.

Every sheet has the same 3 cm spacing, cloth and wind, two pinned corners, 24 fps and 4 implicit
steps per frame, so CG iteration counts stay comparable across sizes. Per size, both paths get
one untimed warm-up step, then the same number of whole frames (or of single steps, scaled to a
frame, where the time budget says so; the table marks it), interleaved fast/reference so that
both see the same load from other jobs on the machine. At 640k the reference path is timed by
one step, scaled, and the fast paths by a whole frame: multigrid refreshes its hierarchy at each
frame's first solve, so a step timed as a frame of its own would pay a whole setup per step. Then, on the fast path's last system: the SpMV alone (median of
repeats, effective bandwidth = bytes it must stream / time) and the same solve done from zero by
the fast PCG and by Eigen's ConjugateGradient in double to the same relative residual. A
STREAM triad (C++, same process, same threads) gives the machine's bandwidth: once at the start
and again right after each SpMV measurement, which the SpMV/triad column uses.

The fast path runs twice per size, once per CG preconditioner (block Jacobi, smoothed-aggregation
multigrid; docs/multigrid.md), interleaved with the reference path; the preconditioner table gives
iterations, multigrid setup, solve and whole-step time and the speed-up of multigrid over block
Jacobi measured in the same run. `--sizes 16,32,64` runs sheets of those sides instead (one frame
each), for the small sizes at which `solver.preconditioner: auto` switches. `--repeat N` times N
blocks of frames per size on the two fast paths (the reference path only the first) and gives
multigrid's speed-up per block, its median and range: on a shared machine one block's ratio
has varied by 30% from the next.
"""

from __future__ import annotations

import json
import math
import os
import statistics
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable

SPACING = 0.03
FPS = 24.0
SUBSTEPS = 4
MATERIAL = {"density": 0.3, "stretch_warp": 3000.0, "stretch_weft": 2000.0, "shear": 150.0, "bend": 2e-5,
            "damping": 0.001}


@dataclass
class Size:
    name: str
    side: int        # vertices per side
    frames: int      # timed frames of SUBSTEPS steps per path (0: `steps` single steps, scaled to a frame)
    steps: int = 0
    # > 0: the reference path times this many single steps, scaled to a frame, while the fast
    # paths time `frames` whole frames. A single step timed as a frame of its own would make
    # multigrid recompute its whole hierarchy at every step (its values are refreshed at each
    # frame's first solve), which no frame of SUBSTEPS steps does.
    reference_steps: int = 0


SIZES = [
    Size("sheet-10k", 100, 2),
    Size("sheet-40k", 200, 1),
    Size("sheet-160k", 400, 1),  # a whole frame: multigrid reuses its hierarchy within a frame
    Size("sheet-640k", 800, 1, reference_steps=1),
]
QUICK_SIZES = [Size("sheet-2.5k", 50, 1), Size("sheet-10k", 100, 0, steps=1)]
PRECONDITIONERS = ("block_jacobi", "multigrid")  # the fast path's runs per size, in this order


def custom_sizes(sides: list[int]) -> list[Size]:
    """One frame each; from 640k vertices on the reference path by one step, scaled (as SIZES)."""
    return [Size(f"sheet-{side * side}", side, 1, reference_steps=1 if side >= 800 else 0) for side in sides]


@dataclass
class PathRecord:
    scene: str
    vertices: int
    path: str
    preconditioner: str           # "block_jacobi" or "multigrid" (fast path); "jacobi" (reference: Eigen's)
    precision: str
    threads: int
    measured: str                 # what was timed, e.g. "2 frames" or "1 of 4 steps, scaled"
    build_s_per_frame: float
    solve_s_per_frame: float
    sim_s_per_frame: float
    s_per_step: float
    cg_iterations_per_step: float
    force_elements: int
    per_force_elements: int
    bandwidth_natural: int
    bandwidth: int
    narrow_columns: bool
    extra: dict[str, Any] = field(default_factory=dict)


def sheet_document(side: int) -> dict[str, Any]:
    from scenes.builders import sheet_shot

    width = SPACING * (side - 1)
    return sheet_shot(
        f"bench-{side}", side, side, width, width, pins=[0, side - 1], fps=FPS, frames=2, substeps=SUBSTEPS,
        air_drag=0.4, wind={"velocity": [1.5, 0.0, 3.0], "gust_amplitude": 0.5, "gust_frequency": 0.7},
        material=MATERIAL, solver={"cg_tolerance": 1e-5, "cg_max_iterations": 2000},
    )


class PathRun:
    """One path's simulation and what has been timed on it so far."""

    def __init__(self, scene: Any, path: str, threads: int, preconditioner: str = "block_jacobi") -> None:
        from weft import _solver
        from weft.solver_setup import build_setup

        self.path, self.threads, self.preconditioner = path, threads, preconditioner
        setup = build_setup(scene, threads, path)
        solver = setup.solver
        solver.preconditioner = {"block_jacobi": _solver.Preconditioner.BLOCK_JACOBI,
                                 "multigrid": _solver.Preconditioner.MULTIGRID}[preconditioner]
        setup.solver = solver
        self.sim = _solver.Simulation(setup)
        self.build = self.solve = self.overhead = 0.0
        self.iterations = self.steps = 0
        self.time = 0.0
        self.setup_before = 0.0  # multigrid setup seconds before the timed frames
        self.refreshes_before = 0  # multigrid refreshes (solves that recomputed its values) before them

    @property
    def label(self) -> str:
        return self.path if self.path == "reference" or self.preconditioner == "block_jacobi" else "fast+multigrid"

    def advance(self, duration: float, substeps: int) -> None:
        t = self.sim.advance_frame(self.time, duration, substeps)
        self.time += duration
        self.build += t.build_seconds
        self.solve += t.solve_seconds
        self.overhead += t.total_seconds - t.build_seconds - t.solve_seconds  # once per frame (energies)
        self.iterations += t.cg_iterations
        self.steps += substeps


def measure_size(scene: Any, size: Size, threads: int, repeat: int = 1) -> tuple[list[PathRecord], PathRecord, Any]:
    """The fast path once per preconditioner and the reference path, their timed frames or steps
    interleaved so that all see the same machine load. With `repeat` > 1 the two fast paths time
    that many blocks of frames (the reference path only the first), and the multigrid record
    keeps each block's solve speed-up over block Jacobi (`solve_speedup_runs`): the spread of
    one machine's load over the run."""
    from weft import _solver

    runs = [PathRun(scene, "fast", threads, p) for p in PRECONDITIONERS] + [PathRun(scene, "reference", threads)]
    h = 1.0 / FPS / SUBSTEPS
    for run in runs:  # warm-up step: first touch of every buffer (and the multigrid structure)
        run.sim.advance_frame(0.0, h, 1)
        run.time = h
        info = _solver.linear_system_info(run.sim)
        run.setup_before, run.refreshes_before = info.multigrid_setup_seconds, info.multigrid_refreshes
    speedups = []
    for block in range(repeat):
        timed = runs if block == 0 else runs[:-1]
        solve_before = [run.solve for run in timed]
        for run in timed:
            if run.path == "reference" and size.reference_steps:
                for _ in range(size.reference_steps):
                    run.advance(h, 1)
        for _ in range(size.frames or size.steps):
            for run in timed:
                if run.path == "reference" and size.reference_steps:
                    continue
                if size.frames:
                    run.advance(SUBSTEPS * h, SUBSTEPS)
                else:
                    run.advance(h, 1)
        block_jacobi, multigrid = (run.solve - before for run, before in zip(timed[:2], solve_before))
        speedups.append(block_jacobi / multigrid)
    records = []
    for run in runs:
        frames = run.steps / SUBSTEPS
        whole_frames = bool(size.frames) and not (run.path == "reference" and size.reference_steps)
        overhead_per_frame = run.overhead / (run.steps / (SUBSTEPS if whole_frames else 1))
        build, solve = run.build / frames, run.solve / frames
        total = build + solve + overhead_per_frame
        blocks = repeat if run.path == "fast" else 1
        steps = size.reference_steps if run.path == "reference" and size.reference_steps else size.steps
        measured = f"{blocks * size.frames} frame{'s' if blocks * size.frames > 1 else ''}" if whole_frames else \
            f"{blocks * steps} of {SUBSTEPS} steps, scaled"
        info = _solver.linear_system_info(run.sim)
        records.append(PathRecord(
            scene=size.name, vertices=scene.vertex_count, path=run.label,
            preconditioner=run.preconditioner if run.path == "fast" else "jacobi", precision=info.precision,
            threads=threads, measured=measured, build_s_per_frame=build, solve_s_per_frame=solve,
            sim_s_per_frame=total, s_per_step=total / SUBSTEPS, cg_iterations_per_step=run.iterations / run.steps,
            force_elements=info.force_elements, per_force_elements=info.per_force_elements,
            bandwidth_natural=info.bandwidth_natural, bandwidth=info.bandwidth, narrow_columns=info.narrow_columns,
        ))
        if run.preconditioner == "multigrid":
            records[-1].extra = {
                "multigrid_setup_s_per_frame": (info.multigrid_setup_seconds - run.setup_before) / frames,
                "multigrid_refreshes_per_step": (info.multigrid_refreshes - run.refreshes_before) / run.steps,
                "multigrid_structure_seconds": info.multigrid_structure_seconds,
                "multigrid_rows": list(info.multigrid_rows),
                "multigrid_operator_complexity": info.multigrid_operator_complexity,
                "solve_speedup_runs": speedups,
            }
    fast_sim = runs[0].sim
    del runs
    return records[:-1], records[-1], fast_sim


def fast_extras(sim: Any, threads: int, tolerance: float) -> dict[str, Any]:
    from weft import _solver

    seconds, nbytes = _solver.time_spmv(sim, 15)
    # The triad again, right after this SpMV: other jobs' load changes within a run, and the
    # ratio is only meaningful between figures taken under the same load.
    triad = _solver.stream_triad_bandwidth(20_000_000, 5, threads)
    compare = _solver.compare_with_eigen_cg(sim, tolerance)
    return {
        "spmv_seconds": seconds,
        "spmv_bytes": nbytes,
        "spmv_gb_per_s": nbytes / seconds / 1e9,
        "triad_gb_per_s": triad / 1e9,
        "spmv_fraction_of_triad": nbytes / seconds / triad,
        "same_system_fast_pcg_seconds": compare["fast_seconds"],
        "same_system_fast_pcg_iterations": compare["fast_iterations"],
        "same_system_fast_pcg_residual": compare["fast_residual"],
        "same_system_eigen_cg_seconds": compare["eigen_seconds"],
        "same_system_eigen_cg_iterations": compare["eigen_iterations"],
        "same_system_eigen_cg_residual": compare["eigen_residual"],
        "eigen_cg_over_fast_pcg": compare["eigen_seconds"] / compare["fast_seconds"],
    }


def run_bench(threads: int = 2, quick: bool = False, log: Callable[[str], None] = print,
              sides: list[int] | None = None, repeat: int = 1) -> dict[str, Any]:
    from weft import _solver
    from weft.shot import parse_shot
    from weft.solver_setup import resolve_scene

    started = time.perf_counter()
    load_before = os.getloadavg()[0]
    triad = _solver.stream_triad_bandwidth(20_000_000, 10, threads)
    log(f"STREAM triad ({threads} threads, 3 x 160 MB): {triad / 1e9:.1f} GB/s; "
        f"OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}")
    records: list[PathRecord] = []
    for size in custom_sizes(sides) if sides else QUICK_SIZES if quick else SIZES:
        document = sheet_document(size.side)
        scene = resolve_scene(parse_shot(document), Path.cwd())
        del document
        (fast, multigrid), reference, sim = measure_size(scene, size, threads, repeat)
        fast.extra = fast_extras(sim, threads, 1e-5)
        del sim
        log(f"{size.name}: fast {fast.sim_s_per_frame:.3f} s/frame (multigrid {multigrid.sim_s_per_frame:.3f}), "
            f"reference {reference.sim_s_per_frame:.3f} s/frame")
        fast.extra.update({
            "build_speedup": reference.build_s_per_frame / fast.build_s_per_frame,
            "solve_speedup": reference.solve_s_per_frame / fast.solve_s_per_frame,
            "sim_speedup": reference.sim_s_per_frame / fast.sim_s_per_frame,
        })
        multigrid.extra.update({
            "solve_speedup_over_block_jacobi": fast.solve_s_per_frame / multigrid.solve_s_per_frame,
            "sim_speedup_over_block_jacobi": fast.sim_s_per_frame / multigrid.sim_s_per_frame,
            "iteration_ratio_block_jacobi": fast.cg_iterations_per_step / max(multigrid.cg_iterations_per_step, 1e-9),
        })
        records += [fast, multigrid, reference]
    return {
        "threads": threads,
        "repeat": repeat,
        "substeps_per_frame": SUBSTEPS,
        "fps": FPS,
        "spacing_m": SPACING,
        "triad_gb_per_s": triad / 1e9,
        "wall_seconds": time.perf_counter() - started,
        # Other jobs on the machine skew every figure; the 1-minute load average says how much.
        "load_average_start": load_before,
        "load_average_end": os.getloadavg()[0],
        "records": [asdict(r) for r in records],
    }


def growth_exponent(xs: list[float], ys: list[float]) -> float:
    """Least-squares slope of log y against log x."""
    lx, ly = [math.log(x) for x in xs], [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)


def speedup_text(extra: dict[str, Any]) -> str:
    """Multigrid's solve speed-up over block Jacobi: over all timed frames, and with repeated
    blocks the median and range of the blocks' own ratios."""
    text = f"{extra['solve_speedup_over_block_jacobi']:.2f}"
    runs = extra.get("solve_speedup_runs", [])
    if len(runs) > 1:
        text += f" (median {statistics.median(runs):.2f}, {min(runs):.2f}-{max(runs):.2f})"
    return text


def format_tables(result: dict[str, Any]) -> str:
    records = result["records"]
    fast = [r for r in records if r["path"] == "fast"]
    ref = {r["scene"]: r for r in records if r["path"] == "reference"}
    lines = [
        f"Table 1 shape: seconds per frame ({result['substeps_per_frame']} steps/frame, {result['threads']} threads; "
        f"STREAM triad {result['triad_gb_per_s']:.1f} GB/s at the start, again beside each SpMV)",
        "",
        "| scene | vertices | path | measured | build | solve | sim/frame | CG it/step | build x | solve x | sim x "
        "| SpMV GB/s | triad GB/s | SpMV/triad |",
        "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for f in fast:
        r, e = ref[f["scene"]], f["extra"]
        lines.append(
            f"| {f['scene']} | {f['vertices']} | fast ({f['precision']}) | {f['measured']} | {f['build_s_per_frame']:.3f} "
            f"| {f['solve_s_per_frame']:.3f} | {f['sim_s_per_frame']:.3f} | {f['cg_iterations_per_step']:.0f} "
            f"| {e['build_speedup']:.2f} | {e['solve_speedup']:.2f} | {e['sim_speedup']:.2f} "
            f"| {e['spmv_gb_per_s']:.1f} | {e['triad_gb_per_s']:.1f} | {100 * e['spmv_fraction_of_triad']:.0f}% |")
        lines.append(
            f"| | | reference | {r['measured']} | {r['build_s_per_frame']:.3f} | {r['solve_s_per_frame']:.3f} "
            f"| {r['sim_s_per_frame']:.3f} | {r['cg_iterations_per_step']:.0f} | | | | | | |")
    multigrid = [r for r in records if r["path"] == "fast+multigrid"]
    bj = {r["scene"]: r for r in fast}
    lines += [
        "",
        "CG preconditioner of the fast path, same run (seconds per frame; solve includes the multigrid setup):",
        "",
        "| scene | vertices | preconditioner | CG it/step | setup | refreshes/step | solve | sim/frame | solve x | sim x "
        "| levels (rows) | op. complexity |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---|---:|",
    ]
    for m in multigrid:
        b, e = bj[m["scene"]], m["extra"]
        lines.append(
            f"| {b['scene']} | {b['vertices']} | block Jacobi | {b['cg_iterations_per_step']:.0f} | | | "
            f"{b['solve_s_per_frame']:.3f} | {b['sim_s_per_frame']:.3f} | | | | |")
        lines.append(
            f"| | | multigrid | {m['cg_iterations_per_step']:.1f} | {e['multigrid_setup_s_per_frame']:.3f} "
            f"| {e.get('multigrid_refreshes_per_step', float('nan')):.2f} | {m['solve_s_per_frame']:.3f} "
            f"| {m['sim_s_per_frame']:.3f} | {speedup_text(e)} "
            f"| {e['sim_speedup_over_block_jacobi']:.2f} | {' / '.join(str(r) for r in e['multigrid_rows'])} "
            f"| {e['multigrid_operator_complexity']:.2f} |")
    lines += [
        "",
        "Same system solved from zero to the same relative residual (the fast path's last step):",
        "",
        "| vertices | fast PCG s (it) | Eigen CG double s (it) | Eigen / fast |",
        "|---:|---:|---:|---:|",
    ]
    for f in fast:
        e = f["extra"]
        lines.append(
            f"| {f['vertices']} | {e['same_system_fast_pcg_seconds']:.3f} ({e['same_system_fast_pcg_iterations']}) "
            f"| {e['same_system_eigen_cg_seconds']:.3f} ({e['same_system_eigen_cg_iterations']}) "
            f"| {e['eigen_cg_over_fast_pcg']:.2f} |")
    lines += [
        "",
        "Cost growth (fast path):",
        "",
        "| vertices | s/step | us per vertex-step | ns per vertex per CG iteration | reference s/step "
        "| elements (aggregated / one per force) | block bandwidth natural -> RCM | 16-bit columns |",
        "|---:|---:|---:|---:|---:|---|---|---|",
    ]
    for f in fast:
        r = ref[f["scene"]]
        per_iteration = f["s_per_step"] / max(f["cg_iterations_per_step"], 1) / f["vertices"] * 1e9
        lines.append(
            f"| {f['vertices']} | {f['s_per_step']:.4f} | {1e6 * f['s_per_step'] / f['vertices']:.2f} "
            f"| {per_iteration:.1f} | {r['s_per_step']:.4f} | {f['force_elements']} / {f['per_force_elements']} "
            f"({100 * (1 - f['force_elements'] / f['per_force_elements']):.0f}% fewer) "
            f"| {f['bandwidth_natural']} -> {f['bandwidth']} | {'yes' if f['narrow_columns'] else 'no (32-bit fallback)'} |")
    if len(fast) > 1:
        xs = [f["vertices"] for f in fast]
        lines.append("")
        lines.append(
            f"Growth exponent (log-log slope) of fast s/step against vertices: "
            f"{growth_exponent(xs, [f['s_per_step'] for f in fast]):.2f}; "
            f"of s per CG iteration: "
            f"{growth_exponent(xs, [f['s_per_step'] / max(f['cg_iterations_per_step'], 1) for f in fast]):.2f}"
            + (f"; with multigrid, of s/step: {growth_exponent(xs, [m['s_per_step'] for m in multigrid]):.2f}."
               if len(multigrid) == len(fast) else "."))
    lines.append(
        f"Bench wall time: {result['wall_seconds']:.0f} s; 1-minute load average {result['load_average_start']:.1f} "
        f"at start, {result['load_average_end']:.1f} at end (this machine has {os.cpu_count()} cores).")
    return "\n".join(lines)


def parse_thread_counts(text: str) -> list[int]:
    """`--threads`: one count or a comma-separated list of counts (each 1-256) and `all`, the CPUs
    this process may run on (`weft.simulate.usable_cpus`), e.g. "1,2,all". Repeats are dropped,
    the order kept. Raises ValueError naming what is wrong."""
    from weft.simulate import usable_cpus

    counts: list[int] = []
    for token in (t.strip().lower() for t in text.split(",") if t.strip()):
        if token == "all":
            count = usable_cpus()
        elif token.isdigit() and 1 <= int(token) <= 256:
            count = int(token)
        else:
            raise ValueError(f"{token!r} is not a thread count: give 1-256 or 'all', comma-separated (e.g. 1,2,all)")
        if count not in counts:
            counts.append(count)
    if not counts:
        raise ValueError("no thread count given (e.g. 2, or 1,2,all)")
    return counts


def thread_rows(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per size and thread count: both preconditioners' iterations and solve time, multigrid's
    speed-up over block Jacobi and its frame time against the first count's (the strong scaling).
    Iterations must not depend on the thread count (the step is bitwise the same for any)."""
    rows: list[dict[str, Any]] = []
    first: dict[str, float] = {}
    for run in runs:
        bj = {r["scene"]: r for r in run["records"] if r["path"] == "fast"}
        for m in (r for r in run["records"] if r["path"] == "fast+multigrid"):
            b = bj[m["scene"]]
            first.setdefault(m["scene"], m["sim_s_per_frame"])
            rows.append({
                "scene": m["scene"], "vertices": m["vertices"], "threads": run["threads"],
                "triad_gb_per_s": run["triad_gb_per_s"],
                "block_jacobi_iterations_per_step": b["cg_iterations_per_step"],
                "multigrid_iterations_per_step": m["cg_iterations_per_step"],
                "block_jacobi_solve_s_per_frame": b["solve_s_per_frame"],
                "multigrid_solve_s_per_frame": m["solve_s_per_frame"],
                "multigrid_setup_s_per_frame": m["extra"]["multigrid_setup_s_per_frame"],
                "multigrid_solve_speedup_over_block_jacobi": b["solve_s_per_frame"] / m["solve_s_per_frame"],
                "multigrid_sim_s_per_frame": m["sim_s_per_frame"],
                "multigrid_sim_speedup_over_first_count": first[m["scene"]] / m["sim_s_per_frame"],
            })
    return rows


def format_thread_table(rows: list[dict[str, Any]]) -> str:
    counts = sorted({r["threads"] for r in rows}, key=[r["threads"] for r in rows].index)
    lines = [
        f"Thread counts {', '.join(map(str, counts))}, same sizes (seconds per frame; solve includes the multigrid "
        f"setup; scaling: multigrid's frame time on {counts[0]} thread(s) over this one's):",
        "",
        "| scene | vertices | threads | triad GB/s | BJ it/step | MG it/step | BJ solve | MG setup | MG solve "
        "| MG over BJ | MG sim/frame | scaling |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in sorted(rows, key=lambda r: (r["vertices"], counts.index(r["threads"]))):
        lines.append(
            f"| {r['scene']} | {r['vertices']} | {r['threads']} | {r['triad_gb_per_s']:.1f} "
            f"| {r['block_jacobi_iterations_per_step']:.0f} | {r['multigrid_iterations_per_step']:.1f} "
            f"| {r['block_jacobi_solve_s_per_frame']:.3f} | {r['multigrid_setup_s_per_frame']:.3f} "
            f"| {r['multigrid_solve_s_per_frame']:.3f} | {r['multigrid_solve_speedup_over_block_jacobi']:.2f} "
            f"| {r['multigrid_sim_s_per_frame']:.3f} | {r['multigrid_sim_speedup_over_first_count']:.2f} |")
    same = all(
        len({(r["block_jacobi_iterations_per_step"], r["multigrid_iterations_per_step"])
             for r in rows if r["scene"] == scene}) == 1
        for scene in {r["scene"] for r in rows})
    lines += ["", "CG iterations the same for every thread count: " + ("yes." if same else "NO (the step should be "
                                                                        "bitwise the same for any thread count).")]
    return "\n".join(lines)


def main(threads: int | list[int] = 2, json_path: Path | None = None, quick: bool = False,
         sides: list[int] | None = None, repeat: int = 1) -> dict[str, Any]:
    """One thread count: the tables and JSON of one run. Several (`--threads 1,2,all`): one run per
    count, in order, each printed as it ends, then the thread table; the JSON holds every run."""
    counts = [threads] if isinstance(threads, int) else threads
    runs = []
    for count in counts:
        result = run_bench(threads=count, quick=quick, sides=sides, repeat=repeat)
        print(format_tables(result), flush=True)
        runs.append(result)
    if len(runs) == 1:
        combined = runs[0]
    else:
        rows = thread_rows(runs)
        print("\n" + format_thread_table(rows))
        combined = {"thread_counts": counts, "runs": runs, "thread_table": rows}
    if json_path is not None:
        json_path.write_text(json.dumps(combined, indent=2))
    return combined


if __name__ == "__main__":  # pragma: no cover
    main()
