"""The implicit integrator against analytic answers: free fall, a hanging strip, energy,
first-order convergence, and stability on a stiff sheet at one substep per frame."""

from __future__ import annotations

import numpy as np

from scenes.builders import sheet_shot

from tests.helpers import make_sim

G = np.array([0.0, -9.81, 0.0])


def advance(sim, frames: int, fps: float, substeps: int, start_frame: int = 0):
    for k in range(frames):
        sim.advance_frame((start_frame + k) / fps, 1.0 / fps, substeps)


def test_free_fall_follows_discrete_backward_euler() -> None:
    # The integrator's arithmetic, checked to a tolerance tighter than a shot's default (1e-3).
    doc = sheet_shot("fall", 8, 8, 0.5, 0.5, plane="xz", frames=24, substeps=4,
                     material={"damping": 0.01, "bend": 1e-4}, solver={"cg_tolerance": 1e-5})
    scene, sim = make_sim(doc)
    masses = np.asarray(sim.vertex_mass)
    x0 = scene.positions.copy()
    com0 = masses @ x0 / masses.sum()
    fps, substeps, frames = 24.0, 4, 24
    h = 1.0 / (fps * substeps)
    advance(sim, frames, fps, substeps)
    n = frames * substeps
    # Discrete backward Euler: v_k = k h g, x_n = x_0 + h^2 g n (n + 1) / 2.
    expected = com0 + h * h * G * n * (n + 1) / 2
    com = masses @ sim.positions / masses.sum()
    displacement = np.linalg.norm(expected - com0)
    assert np.linalg.norm(com - expected) / displacement < 1e-6
    # The shape does not change: positions relative to the centre of mass stay put (to the
    # same relative accuracy, 1e-6 of the sheet's size; the CG tolerance is 1e-5).
    size = 0.5
    shape_change = np.abs((sim.positions - com) - (x0 - com0)).max()
    assert shape_change < 1e-6 * size
    speed = np.linalg.norm(G) * n * h
    assert np.abs(sim.velocities - G * n * h).max() < 1e-6 * speed


def test_hanging_strip_elongation_matches_analytic() -> None:
    """A strip pinned along its top edge: static elongation rho g L^2 / (2 k)."""
    density, stiffness, length = 0.2, 20.0, 1.0
    doc = sheet_shot(
        "strip", 3, 41, 0.1, length, pins=[0, 1, 2],
        material={"density": density, "stretch_warp": stiffness, "stretch_weft": stiffness, "shear": 5.0,
                  "bend": 0.0, "damping": 0.05},
        frames=150, substeps=2, air_drag=0.5,
    )
    scene, sim = make_sim(doc)
    advance(sim, 150, 24.0, 2)
    assert np.abs(sim.velocities).max() < 1e-4  # at rest
    top = scene.positions[:3, 1].mean()
    bottom = sim.positions[-3:, 1].mean()
    elongation = (top - bottom) - length
    analytic = density * 9.81 * length**2 / (2 * stiffness)
    assert abs(elongation - analytic) / analytic < 0.02, (elongation, analytic)


def swinging_sheet(substeps: int, cg_tolerance: float = 1e-10, n: int = 6, stiffness: float = 500.0):
    """A horizontal sheet pinned along one edge, released to swing down. No damping, no drag."""
    doc = sheet_shot(
        "swing", n, n, 0.3, 0.3, plane="xz", pins=list(range(n)),
        material={"stretch_warp": stiffness, "stretch_weft": stiffness, "shear": stiffness / 10,
                  "bend": 1e-4, "damping": 0.0},
        substeps=substeps, solver={"cg_tolerance": cg_tolerance, "cg_max_iterations": 2000},
    )
    return make_sim(doc)


def test_energy_never_increases_without_damping() -> None:
    _, sim = swinging_sheet(substeps=1, cg_tolerance=1e-10)
    energies = [sim.energies().total]
    kinetic = [0.0]
    for step in range(500):
        sim.advance_frame(step / 240.0, 1.0 / 240.0, 1)
        e = sim.energies()
        energies.append(e.total)
        kinetic.append(e.kinetic)
    energies = np.asarray(energies)
    scale = np.abs(energies).max()
    increases = np.diff(energies)
    assert increases.max() <= 1e-9 * scale, f"energy rose by {increases.max():.3e} J at step {increases.argmax()}"
    assert energies[-1] < energies[0]  # backward Euler dissipates
    # And it really swung: a substantial share of the energy became motion at some point.
    assert max(kinetic) > 0.2 * (energies[0] - energies.min())


def test_first_order_convergence() -> None:
    frames, fps = 2, 24.0  # 1/12 s of swing: long enough to move, inside the asymptotic regime
    finals = {}
    for substeps in (1, 2, 4, 8, 64):
        _, sim = swinging_sheet(substeps)
        advance(sim, frames, fps, substeps)
        finals[substeps] = sim.positions.copy()
    reference = finals.pop(64)
    steps = np.array(sorted(finals))
    errors = np.array([np.abs(finals[s] - reference).max() for s in steps])
    assert np.all(np.diff(errors) < 0), errors
    slope = np.polyfit(np.log(1.0 / steps), np.log(errors), 1)[0]
    assert 0.8 < slope < 1.2, (slope, errors)


def test_stiff_sheet_is_stable_at_one_substep_per_frame() -> None:
    doc = sheet_shot(
        "stiff", 64, 64, 1.0, 1.0, pins=[0, 63],
        material={"stretch_warp": 1e4, "stretch_weft": 1e4, "shear": 1e3},
        frames=240, substeps=1, solver={"cg_max_iterations": 300},
    )
    _, sim = make_sim(doc, threads=2)
    initial = sim.energies().total
    totals, kinetic = [], []
    for k in range(239):
        t = sim.advance_frame(k / 24.0, 1.0 / 24.0, 1)
        totals.append(t.kinetic_energy + t.potential_energy)
        kinetic.append(t.kinetic_energy)
    positions = sim.positions
    assert np.isfinite(positions).all() and np.isfinite(sim.velocities).all()
    assert max(totals) <= initial + 1e-6 * abs(initial)  # never gains energy
    # Bounded motion: the sheet hangs below its pins and stays near its size.
    assert positions[:, 1].max() <= 1e-6 and positions[:, 1].min() > -2.0
    assert np.abs(positions[:, [0, 2]]).max() < 2.0


def test_overflowing_forces_fail_the_step_instead_of_freezing(tmp_path) -> None:
    """Forces that overflow must surface as a solver failure at that frame, never as a quiet
    zero update (the PCG used to return dv = 0 for a non-finite right-hand side)."""
    import pytest

    from weft import _solver
    from weft.runner import ShotRunner, SolverFailure

    from tests.helpers import make_scene

    doc = sheet_shot("overflow", 4, 4, 0.2, 0.2, frames=5, gravity=(0.0, -1e300, 0.0))
    with pytest.raises(SolverFailure) as failure:
        ShotRunner(make_scene(doc), tmp_path / "c.h5").run()
    assert failure.value.frame == 2 and "non-finite" in failure.value.reason
    _, sim = make_sim(doc)
    with pytest.raises(_solver.SolverDivergence):
        sim.advance_frame(0.0, 1.0 / 24.0, 1)
