"""Contact benchmark (issue 12, item 7): the procedural contact scenes of `scenes/contact.py` run by
weft and, with `--peer blender`, by Blender cloth in the same run (same scene, same frame count,
same thread count), one table row per (scene, solver), metrics from `bench.contact_metrics`.

    python -m bench.contact [--json PATH] [--peer blender] [--scenes a,b] [--frames N] [--threads 2] [--repeat N]
                            [--perturb N] [--module PATH] [--scene-arg KEY=VALUE ...]

`--scene-arg` passes keyword arguments to the scene builders (`scenes/contact.py`): `--scenes
thin_limb,box_pinch --scene-arg n=96` runs both on a 96 x 96 sheet instead of their bench sizes.

s/frame is the wall time of each simulated frame (weft: `Simulation.advance_frame`; Blender:
`scene.frame_set`), mean and max over the frames after the initial one (the setup, building
the solver or the cloth cache, is reported apart). `ratio` = Blender s/frame / weft s/frame,
measured one after the other in this process's run. With `--repeat N` each scene runs N times,
weft and the peer alternating which goes first; s/frame is then the median of the runs' means
and the table shows the range of the per-repeat ratios (on a shared 2-core machine one run's
ratio has varied by 20% from the next), and weft's repeats must agree bit for bit
(`repeats_identical`). weft's step breakdown (build, solve,
collision and GIA seconds per frame, CG iterations per substep, CCD candidates, proximity
pairs, impact zones, unresolved collisions) comes from its per-frame telemetry. With
`--perturb N` weft also runs N copies of each scene with the cloth thickness perturbed by a few
per cent (`run_perturbed`), and a third table reports the issue's per-frame targets over all of
them (`bench/contact_robustness.py`): one run of a chaotic contact scene shows neither a failure's
frequency nor a fix.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as bench/gia_pinch_cost.py: shared 2-core machines

import argparse  # noqa: E402
import inspect  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from bench.contact_metrics import BodyTrack, contact_metrics, edge_rest_lengths  # noqa: E402

# Frames simulated per scene by default (the initial frame included): `python -m bench.contact`
# over every scene, weft only, in about 10-15 minutes on 2 loaded cores. The dress scenes run 5 s
# of the walk: the legs swing from frame 5, and from frame 88 on the arms close on the torso
# with the dress between them (a pinch between parts of one character, which GIA recovers).
# The loose skirt's 80 frames take it down the dress and into folds around the legs (from
# about frame 40), where its frames cost seconds, not tenths.
DEFAULT_FRAMES = {
    "drape_sphere": 48,
    "drape_sphere_16k": 24,
    "table_cloth": 48,
    "spinning_sphere": 48,
    "fast_drop": 36,
    "towel_bar": 48,
    "curtain_box": 36,
    "sleeve_swing": 24,
    "box_pinch": 25,
    "thin_limb": 16,
    "articulated_dress": 120,
    "articulated_dress_merged": 120,
    "walking_dress": 120,
    "layered_dress": 60,
    "loose_skirt": 80,
    "trousers": 96,
}


def build_scene(name: str, directory: Path, frames: int, features: dict[str, Any] | None = None,
                thickness_scale: float = 1.0, scene_args: dict[str, Any] | None = None) -> Any:
    """The resolved weft scene of a named contact scene, at least `frames` long when the builder
    takes a frame count; `features` overrides switches of the shot's `features`;
    `thickness_scale` scales every cloth piece's thickness (`--perturb`); `scene_args` are more
    keyword arguments of the scene's builder (`--scene-arg`, checked by `scene_arg_errors`)."""
    from scenes.contact import SCENES
    from weft.shot import parse_shot
    from weft.solver_setup import resolve_scene

    make = SCENES[name]
    kwargs = {"frames": frames} if "frames" in inspect.signature(make).parameters else {}
    kwargs.update(scene_args or {})
    shot = make(directory, **kwargs)
    if features:
        shot["features"] = {**shot.get("features", {}), **features}
    if thickness_scale != 1.0:
        from bench.contact_robustness import scale_thickness

        scale_thickness(shot, thickness_scale)
    return resolve_scene(parse_shot(shot), directory)


def parse_scene_args(items: list[str]) -> dict[str, Any]:
    """`--scene-arg KEY=VALUE` items as builder keyword arguments: VALUE as an int, else a float,
    else the string. ValueError names an item without `=` or with an empty key."""
    parsed: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"{item!r} is not KEY=VALUE")
        value: Any = text
        for kind in (int, float):
            try:
                value = kind(text)
                break
            except ValueError:
                continue
        parsed[key.strip()] = value
    return parsed


def scene_arg_errors(names: list[str], scene_args: dict[str, Any]) -> list[str]:
    """Why `scene_args` cannot go to every named scene's builder: a key one of them does not take
    (its own parameters are listed), or `frames`, which `--frames` sets. A builder that passes
    further keywords on (`**kwargs`: the dresses) is tried once, two frames long, in a scratch
    directory."""
    from scenes.contact import SCENES

    if "frames" in scene_args:
        return ["frames is set by --frames"]
    errors = []
    for name in names:
        parameters = inspect.signature(SCENES[name]).parameters
        if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
            with tempfile.TemporaryDirectory(prefix=f"weft-scene-args-{name}-") as tmp:
                try:
                    SCENES[name](Path(tmp), frames=2, **scene_args)
                except TypeError as exc:
                    errors.append(f"{name}: {exc}")
            continue
        own = [p for p in parameters if p not in ("directory", "frames")]
        errors += [f"{name} takes no {key!r} (its arguments: {', '.join(own) or 'none'})"
                   for key in scene_args if key not in own]
    return errors


def run_weft(scene: Any, frames: int, threads: int) -> dict[str, Any]:
    """Simulates the first `frames` frames (the initial state included; at most the scene's own,
    for a builder that sets its length) keeping every frame's positions in memory; stops at a
    solver failure."""
    from weft.simulate import SolverFailure, advance, new_simulation, telemetry_row
    from weft.thread_governor import ThreadGovernor

    frames = min(frames, scene.frame_count)
    shot = scene.shot
    start = time.perf_counter()
    sim = new_simulation(scene, threads)
    governor = ThreadGovernor(sim, threads)
    setup = time.perf_counter() - start
    positions, seconds, telemetry, failure = [np.array(sim.positions)], [], [], None
    for index in range(1, frames):
        start = time.perf_counter()
        try:
            t = advance(sim, scene, index, governor)
        except SolverFailure as exc:
            failure = str(exc)
            break
        seconds.append(time.perf_counter() - start)
        telemetry.append(telemetry_row(shot.frame_range[0] + index, t, governor))
        positions.append(np.array(sim.positions))
    return {"positions": np.stack(positions), "frame_seconds": np.asarray(seconds), "setup_seconds": setup,
            "telemetry": telemetry, "failure": failure}


def weft_breakdown(telemetry: list[Any]) -> dict[str, Any]:
    """Means per simulated frame of weft's telemetry (CG iterations per substep)."""
    if not telemetry:
        return {}

    def column(name: str) -> np.ndarray:
        return np.array([getattr(t, name) for t in telemetry], dtype=np.float64)

    substeps = column("substeps").sum()
    out = {f"{name}_per_frame": float(column(name).mean()) for name in (
        "build_seconds", "solve_seconds", "setup_seconds", "collision_seconds", "gia_seconds", "total_seconds",
        "collision_broad_phase_seconds", "collision_proximity_seconds", "collision_ccd_seconds",
        "collision_response_seconds", "self_collision_seconds", "contact_constraints_seconds",
        "ccd_candidates",
        "broad_phase_pairs", "proximity_pairs", "contact_constraints", "released_contacts", "impact_zones")}
    out["collision_share"] = float(column("collision_seconds").sum() / max(column("total_seconds").sum(), 1e-300))
    out.update({
        "cg_iterations_per_substep": float(column("cg_iterations").sum() / max(substeps, 1.0)),
        "unconverged_substeps": int(column("unconverged_substeps").sum()),
        "impact_zones_total": int(column("impact_zones").sum()),
        "unresolved_collisions_total": int(column("unresolved_collisions").sum()),
        "gia_coloured_vertices_max": int(column("gia_coloured_vertices").max()),
        "intersections_final": int(column("intersections")[-1]),
    })
    return out


def frames_inside(inside: list[int], telemetry: list[Any]) -> dict[str, int]:
    """Frames ending with cloth vertices inside a body, and of those the ones no pinch held
    (no body/body and no part pinch engaged in the frame): GIA's rules allow the first kind only
    where two bodies or two parts of a character close on the cloth. inside[k] is frame k's
    count (k = 0 the initial state), telemetry[k - 1] its frame's row."""
    pinched = [t.gia_pinched_body_pairs + t.gia_pinched_part_pairs > 0 for t in telemetry]
    flagged = [k for k in range(1, min(len(inside), len(telemetry) + 1)) if inside[k] > 0]
    return {"inside_frames": len(flagged), "inside_frames_unpinched": sum(not pinched[k - 1] for k in flagged)}


def measure(scene: Any, solver: str, run: dict[str, Any], threads: int) -> dict[str, Any]:
    positions = run["positions"]
    bodies = [BodyTrack(b.name, b.faces, np.asarray(b.frames[:len(positions)])) for b in scene.bodies]
    metrics = contact_metrics(positions, scene.faces, edge_rest_lengths(scene.face_uv), bodies,
                              run["frame_seconds"], scene.shot.fps, threads=threads)
    return {"solver": solver, "vertices": scene.vertex_count, "setup_seconds": run["setup_seconds"], **metrics}


def repeated_timing(row: dict[str, Any], frame_seconds: list[np.ndarray]) -> None:
    """s/frame over repeated runs of one solver on one scene: each run's mean, their median (what
    `s_per_frame_mean` then holds) and the slowest frame of any run."""
    means = [float(np.mean(s)) for s in frame_seconds if len(s)]
    row["s_per_frame_runs"] = means
    if means:
        row["s_per_frame_mean"] = float(np.median(means))
        row["s_per_frame_max"] = max(float(np.max(s)) for s in frame_seconds if len(s))


def run_scene(name: str, frames: int | None, threads: int, peer: str | None,
              blender_mass: str = "mapped", self_cost: bool = False, repeat: int = 1,
              scene_args: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """One scene: weft (and the peer) `repeat` times, alternating which goes first, so that both
    see the machine's slow and fast spells alike; metrics from each solver's first run."""
    if repeat < 1:
        raise ValueError("repeat must be at least 1")
    with tempfile.TemporaryDirectory(prefix=f"weft-contact-{name}-") as tmp:
        wanted = frames or DEFAULT_FRAMES[name]
        scene = build_scene(name, Path(tmp), wanted, scene_args=scene_args)
        wanted = min(wanted, scene.frame_count)
        weft_runs: list[dict[str, Any]] = []
        peer_runs: list[dict[str, Any]] = []
        peer_failure: str | None = None

        def run_peer_once() -> None:
            nonlocal peer_failure
            from bench.blender_peer import run_peer

            if peer_failure is None:
                try:
                    peer_runs.append(run_peer(scene, wanted, threads, blender_mass))
                except RuntimeError as exc:
                    peer_failure = str(exc)

        for index in range(repeat):
            peer_first = peer == "blender" and index % 2 == 1
            if peer_first:
                run_peer_once()
            weft_runs.append(run_weft(scene, wanted, threads))
            if peer == "blender" and not peer_first:
                run_peer_once()
        weft_run = weft_runs[0]
        row = measure(scene, "weft", weft_run, threads)
        row.update(scene=name, rest=scene.shot.cloth[0].rest.kind, failure=weft_run["failure"],
                   telemetry=weft_breakdown(weft_run["telemetry"]),
                   telemetry_frames=[t.model_dump() for t in weft_run["telemetry"]])
        row.update(frames_inside(row["per_frame"]["inside"], weft_run["telemetry"]))
        # Frames the thread governor ran on fewer threads than asked (other processes crowded
        # the cores: weft/thread_governor.py), over every repeat: their timings are not comparable.
        row["frames_on_fewer_threads"] = sum(t.threads < threads for r in weft_runs for t in r["telemetry"])
        if repeat > 1:
            repeated_timing(row, [r["frame_seconds"] for r in weft_runs])
            # weft is deterministic: every repeat must give the first run's positions, bit for bit.
            row["repeats_identical"] = all(np.array_equal(r["positions"], weft_run["positions"]) for r in weft_runs)
        rows = [row]
        if self_cost and scene.shot.features.self_collision is not False:
            # The same scene with self-collision switched off, run right after: what it costs.
            off = build_scene(name, Path(tmp), wanted, {"self_collision": False}, scene_args=scene_args)
            off_run = run_weft(off, wanted, threads)
            off_row = measure(off, "weft", off_run, threads)
            off_row.update(scene=name, solver="weft, self off", failure=off_run["failure"],
                           telemetry=weft_breakdown(off_run["telemetry"]))
            if row["s_per_frame_mean"] and off_row["s_per_frame_mean"]:
                row["self_collision_cost"] = row["s_per_frame_mean"] / off_row["s_per_frame_mean"]
                off_row["rest"] = f"self-collision costs {row['self_collision_cost']:.2f}x"
            rows.append(off_row)
        if peer == "blender":
            if not peer_runs:
                rows.append({"scene": name, "solver": "blender", "failure": peer_failure or "no run"})
                return rows
            peer_run = peer_runs[0]
            peer_row = measure(scene, "blender", peer_run, threads)
            info = peer_run["info"]
            peer_row.update(scene=name, rest=f"{info['rest']}; {info['vertex_mass_kg']:.2g} kg/vertex", failure=None,
                            blender=info)
            if repeat > 1:
                repeated_timing(peer_row, [r["frame_seconds"] for r in peer_runs])
                pairs = zip(peer_row["s_per_frame_runs"], row.get("s_per_frame_runs", []))
                peer_row["ratio_runs"] = [b / w for b, w in pairs if w]
            if row["s_per_frame_mean"] and peer_row["s_per_frame_mean"]:
                peer_row["ratio"] = peer_row["s_per_frame_mean"] / row["s_per_frame_mean"]
            rows.append(peer_row)
        return rows


def run_perturbed(name: str, frames: int, threads: int, count: int,
                  scene_args: dict[str, Any] | None = None) -> dict[str, Any]:
    """weft on `count` thickness-perturbed copies of scene `name` (`--perturb`), summarised by
    `bench.contact_robustness`."""
    from bench.contact_robustness import copy_summary, summarise, thickness_factors

    copies = []
    for factor in thickness_factors(count):
        with tempfile.TemporaryDirectory(prefix=f"weft-perturbed-{name}-") as tmp:
            scene = build_scene(name, Path(tmp), frames, thickness_scale=factor, scene_args=scene_args)
            run = run_weft(scene, min(frames, scene.frame_count), threads)
            copies.append(copy_summary(factor, run, measure(scene, "weft", run, threads)))
    return summarise(name, copies)


def _fmt(value: Any, spec: str, scale: float = 1.0) -> str:
    return "-" if value is None else format(value * scale, spec)


def _ratio(row: dict[str, Any]) -> str:
    """The ratio, and with repeats the range of the per-repeat ratios."""
    runs = row.get("ratio_runs") or []
    text = _fmt(row.get("ratio"), ".2f")
    return f"{text} ({min(runs):.2f}-{max(runs):.2f})" if len(runs) > 1 else text


def format_tables(rows: list[dict[str, Any]]) -> list[Any]:
    """The results table (a row per scene and solver) and weft's step breakdown (rich tables)."""
    from rich.table import Table

    main = Table(title="contact benchmark (s/frame: wall, frame 1 setup excluded, median of the repeats' means; "
                       "ratio = blender / weft, (range over the repeats))")
    for column in ("scene", "solver", "verts", "frames", "s/frame", "max s", "ratio", "inside max/fin",
                   "gap min/med mm", "cloth-body max/fin", "cloth-cloth max/fin", "max strain", "max m/s", "NaN",
                   "rest / notes"):
        main.add_column(column, justify="left" if column in ("scene", "solver", "rest / notes") else "right")
    for r in rows:
        if "frames" not in r:
            main.add_row(r["scene"], r["solver"], *["-"] * 12, "failed: " + r["failure"].splitlines()[0][:80])
            continue
        note = r.get("rest", "") if r["solver"] == "weft, self off" else "rest: " + r.get("rest", "")
        if r.get("failure"):
            note += f"; stopped: {r['failure'][:60]}"
        if r.get("inside_frames"):
            note += f"; inside in {r['inside_frames']} frames, {r['inside_frames_unpinched']} unpinched"
        if r.get("repeats_identical") is False:
            note += "; REPEATS DIFFER"
        if r.get("frames_on_fewer_threads"):
            note += f"; {r['frames_on_fewer_threads']} frames on fewer threads (machine busy)"
        main.add_row(
            r["scene"], r["solver"], str(r["vertices"]), str(r["frames"]), _fmt(r["s_per_frame_mean"], ".3f"),
            _fmt(r["s_per_frame_max"], ".3f"), _ratio(r), f"{r['inside_max']}/{r['inside_final']}",
            f"{_fmt(r.get('gap_min_m'), '.1f', 1e3)}/{_fmt(r.get('gap_median_m'), '.1f', 1e3)}",
            f"{r['cloth_body_pairs_max']}/{r['cloth_body_pairs_final']}",
            f"{r['cloth_cloth_pairs_max']}/{r['cloth_cloth_pairs_final']}", _fmt(r["max_strain"], ".3f"),
            _fmt(r["max_speed_m_s"], ".2f"), "yes" if r["nan"] else "no", note,
        )
    steps = Table(title="weft step breakdown (per simulated frame; CG iterations per substep)")
    for column in ("scene", "build s", "solve s", "of which setup s", "collision s", "of which self s",
                   "of which contacts s", "collision share", "gia s",
                   "CG it/substep", "CCD cand/frame", "contacts in solve/frame", "prox pairs/frame", "impact zones", "unresolved",
                   "unconverged"):
        steps.add_column(column, justify="left" if column == "scene" else "right")
    for r in rows:
        t = r.get("telemetry")
        if not r["solver"].startswith("weft") or not t:
            continue
        label = r["scene"] if r["solver"] == "weft" else f"{r['scene']} ({r['solver']})"
        steps.add_row(
            label, *(f"{t[k]:.3f}" for k in ("build_seconds_per_frame", "solve_seconds_per_frame",
                                             "setup_seconds_per_frame", "collision_seconds_per_frame",
                                             "self_collision_seconds_per_frame",
                                             "contact_constraints_seconds_per_frame")),
            f"{t['collision_share']:.0%}", f"{t['gia_seconds_per_frame']:.3f}",
            f"{t['cg_iterations_per_substep']:.0f}", f"{t['ccd_candidates_per_frame']:.0f}",
            f"{t['contact_constraints_per_frame']:.0f}", f"{t['proximity_pairs_per_frame']:.0f}",
            str(t["impact_zones_total"]), str(t["unresolved_collisions_total"]), str(t["unconverged_substeps"]),
        )
    return [main, steps]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.contact", description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path, help="write every number to this JSON file")
    parser.add_argument("--peer", choices=["blender"], help="also run each scene in Blender cloth (bpy)")
    parser.add_argument("--scenes", help=f"comma-separated subset of: {', '.join(DEFAULT_FRAMES)}")
    parser.add_argument("--frames", type=int, help="frames per scene, the initial one included (default: per scene)")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--blender-mass", choices=["mapped", "default"], default="default",
                        help="Blender vertex mass: its default 0.3 kg (default; mapped masses leave Blender's cloth "
                             "floating under its other defaults) or density x area (mapped)")
    parser.add_argument("--repeat", type=int, default=1,
                        help="run each scene this many times (weft and the peer alternating which goes first); "
                             "s/frame is the median of the runs' means, the ratio's range is shown")
    parser.add_argument("--perturb", type=int, default=0, metavar="N",
                        help="also run weft on N copies of each scene with the cloth thickness scaled by 0.93-1.07: "
                             "worst frame, frames with intersections, halvings and strain over all copies")
    parser.add_argument("--self-cost", action="store_true",
                        help="also run weft with self-collision off: the cost of self-collision per scene")
    parser.add_argument("--module", help="path of a weft._solver extension to run instead of the installed one "
                        "(another build, measured against this one in a run of its own)")
    parser.add_argument("--scene-arg", action="append", default=[], metavar="KEY=VALUE",
                        help="a keyword argument of the scene builders in scenes/contact.py, e.g. n=96 for a "
                             "96 x 96 sheet (repeatable; every chosen scene must take it)")
    args = parser.parse_args(argv)
    names = args.scenes.split(",") if args.scenes else list(DEFAULT_FRAMES)
    unknown = [n for n in names if n not in DEFAULT_FRAMES]
    if unknown:
        parser.error(f"unknown scene(s) {unknown}; choose from {list(DEFAULT_FRAMES)}")
    try:
        scene_args = parse_scene_args(args.scene_arg)
    except ValueError as exc:
        parser.error(f"--scene-arg: {exc}")
    errors = scene_arg_errors(names, scene_args)
    if errors:
        parser.error("--scene-arg: " + "; ".join(errors))
    if args.repeat < 1:
        parser.error("--repeat must be at least 1")
    if args.perturb < 0:
        parser.error("--perturb must be 0 (off) or a positive number of copies")
    if args.frames is not None and args.frames < 2:
        parser.error("--frames must be at least 2 (the initial state and one simulated frame)")
    from bench.solver_module import load_module_option

    load_module_option(parser, args.module)
    if args.peer == "blender":
        try:
            import importlib.util

            if importlib.util.find_spec("bpy") is None:
                raise ImportError
        except ImportError:
            from bench.blender_peer import BPY_MISSING

            parser.error(BPY_MISSING)

    from rich.console import Console

    console = Console(width=None if sys.stdout.isatty() else 200)
    load_before = os.getloadavg()
    rows: list[dict[str, Any]] = []
    for name in names:
        console.print(f"[dim]{name} ...[/dim]")
        rows.extend(run_scene(name, args.frames, args.threads, args.peer, args.blender_mass, args.self_cost,
                              args.repeat, scene_args))
    perturbed: list[dict[str, Any]] = []
    if args.perturb:
        for name in names:
            console.print(f"[dim]{name}: {args.perturb} perturbed copies ...[/dim]")
            perturbed.append(run_perturbed(name, args.frames or DEFAULT_FRAMES[name], args.threads, args.perturb,
                                           scene_args))
    for table in format_tables(rows):
        console.print(table)
    if perturbed:
        from bench.contact_robustness import format_table

        console.print(format_table(perturbed, args.perturb))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        report = {"threads": args.threads, "peer": args.peer, "repeat": args.repeat, "blender_mass": args.blender_mass, "cpus": os.cpu_count(), "machine": platform.platform(),
                  "load_average_before": load_before, "load_average_after": os.getloadavg(), "rows": rows,
                  "perturb": args.perturb, "perturbed": perturbed, "module": args.module, "scene_args": scene_args}
        args.json.write_text(json.dumps(report, indent=1, default=float))
        console.print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
