"""`weft report ...`: reports over the regression scenes (imports the `regress` package when it
runs; regress is not part of the library)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from weft.cli.common import console, fail, out

app = typer.Typer(name="report", help="Reports: speed against error, the stability map.", no_args_is_help=True)


@app.command("speed-error")
def speed_error(
    scenes: Annotated[list[str], typer.Argument(help="Regression scenes (weft regress --list)")],
    output: Annotated[Path, typer.Option("-o", "--out", help="Directory for the JSON and the plots")] = Path("out/speed_error"),
    repeats: Annotated[int, typer.Option("--repeats", min=1, max=20, help="Runs per point (median wall time)")] = 3,
    threads: Annotated[int, typer.Option("--threads", min=1, max=256)] = 2,
    within: Annotated[float, typer.Option("--within", min=0.0, help="Error bound (mm RMS) for the cheapest setting")] = 10.0,
) -> None:
    """Sweep the settings that trade time for error (substeps, CG tolerance, preconditioner,
    precision, linear path) on regression scenes: s/frame against error vs the converged
    reference, the Pareto front (PNG per scene), JSON, and the cheapest setting within --within."""
    from regress import speed_error
    from regress.runs import unknown_scenes

    unknown = unknown_scenes(scenes)
    if unknown:
        fail(f"SCENES: unknown scene(s) {', '.join(unknown)} (see `weft regress --list`)")
    report = speed_error.run(scenes, output, repeats, threads, within, lambda m: console.print(f"[dim]{m}[/]"))
    for name, data in report["scenes"].items():
        table = Table("setting", "substeps", "s/frame", "error RMS mm", "error max mm", "Pareto", title=name,
                      title_justify="left")
        for p in data["points"]:
            table.add_row(p["label"], str(p["substeps"]),
                          f"{p['s_per_frame']:.4f}" if p["s_per_frame"] is not None else p["failure"] or "-",
                          f"{p['error_rms_mm']:.3g}" if p["error_rms_mm"] is not None else "-",
                          f"{p['error_max_mm']:.3g}" if p["error_max_mm"] is not None else "-",
                          "*" if p["pareto"] else "")
        out.print(table)
        best = data["cheapest_within"]
        out.print(f"{name}: cheapest within {within:g} mm RMS: "
                  + (f"{best['label']} ({best['s_per_frame']:.4f} s/frame, {best['error_rms_mm']:.3g} mm)" if best
                     else "none"))
        out.print(f"plot: {data['plot']}")
    out.print(f"json: {output / 'speed_error.json'}")


@app.command("stability")
def stability(
    maps: Annotated[str, typer.Option("--maps", help="Comma-separated: stiffness, density, pin_speed, body_speed")] = "",
    json_path: Annotated[Path | None, typer.Option("--json", help="Also write every cell as JSON here")] = None,
) -> None:
    """Where the solver stays finite and bounded: stiffness, density, pin and body speed, each
    against the time step (1/24 .. 1/960 s), on a small pinned sheet. Exit 1 if any run let a
    NaN out (a failure must be a clean, named solver failure)."""
    import json

    from regress import stability as stability_map

    names = [m.strip() for m in maps.split(",") if m.strip()] or list(stability_map.MAPS)
    unknown = [m for m in names if m not in stability_map.MAPS]
    if unknown:
        fail(f"--maps: unknown map(s) {', '.join(unknown)}; known: {', '.join(stability_map.MAPS)}")
    report = stability_map.run(names, lambda m: console.print(f"[dim]{m}[/]"))
    nan = False
    for name, data in report["maps"].items():
        table = Table(data["setting"], *[f"h = 1/{int(report['fps'] * s)} s" for s in report["substeps"]],
                      title=f"{name} against the time step", title_justify="left")
        cells = {(c["value"], c["substeps"]): c for c in data["cells"]}
        for value in data["values"]:
            row = []
            for s in report["substeps"]:
                c = cells[(value, s)]
                nan = nan or c["status"] == "NaN"
                strain = f" {c['max_strain']:.2f}" if c["max_strain"] is not None else ""
                row.append(f"{c['status']}{strain}")
            table.add_row(f"{value:g}", *row)
        out.print(table)
    out.print("cells: status and max edge strain (ok: finite, strain <= 1.5, speeds bounded; failed@F: the solver "
              "stopped cleanly at frame F)")
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps(report, indent=2) + "\n")
        out.print(f"json: {json_path}")
    if nan:
        raise typer.Exit(1)
