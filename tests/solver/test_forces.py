"""Every force term's force and Jacobian against central finite differences (double precision)."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.builders import sheet_shot
from weft import _solver

from tests.helpers import make_sim

T = _solver.ForceTerm
STEP = 1e-6
TOLERANCE = 1e-5


def deformed_sheet(rng: np.random.Generator, damping: float = 0.0, drag: float = 0.0, **material: float):
    """A 5x4 sheet with a curved rest shape, then randomly stretched, compressed and folded."""
    doc = sheet_shot(
        "fd", 5, 4, 0.4, 0.3, plane="xz",
        material={"stretch_warp": 900.0, "stretch_weft": 500.0, "shear": 70.0, "bend": 3e-3, "damping": damping,
                  **material},
        air_drag=drag, wind={"velocity": [0.3, 0.0, -0.2]},
    )
    # Curve the rest shape so that rest dihedral angles are not zero.
    verts = np.asarray(doc["cloth"][0]["mesh"]["vertices"])
    verts[:, 1] = 0.15 * np.sin(4.0 * verts[:, 0]) * np.cos(3.0 * verts[:, 2])
    doc["cloth"][0]["mesh"]["vertices"] = verts.tolist()
    scene, sim = make_sim(doc)
    x = scene.positions.copy()
    spacing = 0.1
    x *= rng.uniform(0.8, 1.2, size=3)  # anisotropic scale: some triangles stretched, some compressed
    x += rng.normal(scale=0.25 * spacing, size=x.shape)
    v = rng.normal(scale=0.5, size=x.shape)
    return sim, x, v


def relative_error(approx: np.ndarray, exact: np.ndarray) -> float:
    return float(np.linalg.norm(approx - exact) / max(np.linalg.norm(exact), 1e-300))


def energy_of(sim, x: np.ndarray, term: int) -> float:
    if term == T.GRAVITY:
        return sim.gravity_energy(x)
    return sim.elastic_energy(x, int(term))


def fd_gradient(fun, x: np.ndarray) -> np.ndarray:
    g = np.zeros(x.size)
    flat = x.ravel()
    for k in range(x.size):
        xp, xm = flat.copy(), flat.copy()
        xp[k] += STEP
        xm[k] -= STEP
        g[k] = (fun(xp.reshape(x.shape)) - fun(xm.reshape(x.shape))) / (2 * STEP)
    return g


def fd_jacobian(fun, x: np.ndarray) -> np.ndarray:
    cols = []
    flat = x.ravel()
    for k in range(x.size):
        xp, xm = flat.copy(), flat.copy()
        xp[k] += STEP
        xm[k] -= STEP
        cols.append((fun(xp.reshape(x.shape)) - fun(xm.reshape(x.shape))) / (2 * STEP))
    return np.stack(cols, axis=1)


CONSERVATIVE = [T.STRETCH, T.SHEAR, T.BEND, T.GRAVITY]


@pytest.mark.parametrize("term", CONSERVATIVE, ids=lambda t: t.name)
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_conservative_force_is_minus_energy_gradient(term, seed) -> None:
    sim, x, v = deformed_sheet(np.random.default_rng(seed))
    force, _, _ = sim.evaluate_forces(x, v, 0.0, int(term), False)
    numeric = -fd_gradient(lambda y: energy_of(sim, y, term), x)
    assert np.linalg.norm(force) > 0.0
    assert relative_error(force, numeric) < TOLERANCE


@pytest.mark.parametrize("term", [T.STRETCH, T.SHEAR, T.BEND], ids=lambda t: t.name)
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_position_jacobian_matches_finite_differences(term, seed) -> None:
    sim, x, v = deformed_sheet(np.random.default_rng(seed))
    _, dfdx, _ = sim.evaluate_forces(x, v, 0.0, int(term), False)
    numeric = fd_jacobian(lambda y: sim.evaluate_forces(y, v, 0.0, int(term), False)[0], x)
    exact = dfdx.toarray()
    assert np.linalg.norm(exact) > 0.0
    assert relative_error(exact, numeric) < TOLERANCE
    assert np.allclose(exact, exact.T, atol=1e-8 * np.abs(exact).max())  # conservative: symmetric


def test_gravity_has_no_position_jacobian(rng) -> None:
    sim, x, v = deformed_sheet(rng)
    force, dfdx, dfdv = sim.evaluate_forces(x, v, 0.0, int(T.GRAVITY), False)
    assert abs(dfdx).sum() == 0.0 and abs(dfdv).sum() == 0.0
    masses = np.asarray(sim.vertex_mass)
    assert np.allclose(force.reshape(-1, 3), masses[:, None] * np.array([0.0, -9.81, 0.0]))


@pytest.mark.parametrize("term", [T.DAMPING, T.DRAG], ids=lambda t: t.name)
@pytest.mark.parametrize("seed", [1, 2])
def test_velocity_jacobian_matches_finite_differences(term, seed) -> None:
    sim, x, v = deformed_sheet(np.random.default_rng(seed), damping=0.01, drag=0.7)
    force, _, dfdv = sim.evaluate_forces(x, v, 0.0, int(term), False)
    numeric = fd_jacobian(lambda w: sim.evaluate_forces(x, w, 0.0, int(term), False)[0], v)
    exact = dfdv.toarray()
    assert np.linalg.norm(force) > 0.0 and np.linalg.norm(exact) > 0.0
    assert relative_error(exact, numeric) < TOLERANCE
    # Dissipative: -dF/dv is symmetric positive semi-definite.
    assert np.allclose(exact, exact.T, atol=1e-12 * np.abs(exact).max())
    assert np.linalg.eigvalsh(-exact).min() > -1e-9 * np.abs(exact).max()


def test_drag_pulls_towards_the_wind(rng) -> None:
    sim, x, _ = deformed_sheet(rng, drag=0.7)
    still = np.zeros_like(x)
    force, _, _ = sim.evaluate_forces(x, still, 0.0, int(T.DRAG), False)
    wind = np.array([0.3, 0.0, -0.2])
    assert np.all(force.reshape(-1, 3) @ wind > 0.0)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_projected_stiffness_is_positive_semidefinite(seed) -> None:
    """The solver's Jacobian (indefinite parts dropped) keeps -dF/dx PSD, even under compression."""
    sim, x, v = deformed_sheet(np.random.default_rng(seed))
    x = x * 0.7  # compress everything
    _, exact_dfdx, _ = sim.evaluate_forces(x, v, 0.0, int(T.ALL), False)
    _, projected_dfdx, _ = sim.evaluate_forces(x, v, 0.0, int(T.ALL), True)
    exact_min = np.linalg.eigvalsh(-exact_dfdx.toarray()).min()
    projected = -projected_dfdx.toarray()
    scale = np.abs(projected).max()
    assert exact_min < -1e-3 * scale  # the exact Jacobian really is indefinite here
    assert np.linalg.eigvalsh(projected).min() > -1e-9 * scale


def test_hinge_angle_sign_and_value() -> None:
    x0, x1 = np.array([0.0, 0, 0]), np.array([1.0, 0, 0])
    flat = _solver.hinge_angle(x0, x1, np.array([0.3, 1.0, 0]), np.array([0.6, -1.0, 0]))
    folded = _solver.hinge_angle(x0, x1, np.array([0.3, 0.0, 1.0]), np.array([0.6, -1.0, 0]))
    assert flat == pytest.approx(0.0, abs=1e-15)
    assert abs(folded) == pytest.approx(np.pi / 2, rel=1e-12)


# -- biphasic stretch (issue 18): soft to the knee, ratio times stiffer past it ----------------
BIPHASIC = {"stretch_knee": 0.02, "stretch_knee_ratio": 12.0}


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_biphasic_stretch_force_and_jacobian_match_finite_differences(seed) -> None:
    sim, x, v = deformed_sheet(np.random.default_rng(seed), **BIPHASIC)
    force, dfdx, _ = sim.evaluate_forces(x, v, 0.0, int(T.STRETCH), False)
    numeric_force = -fd_gradient(lambda y: sim.elastic_energy(y, int(T.STRETCH)), x)
    assert relative_error(force, numeric_force) < TOLERANCE
    numeric = fd_jacobian(lambda y: sim.evaluate_forces(y, v, 0.0, int(T.STRETCH), False)[0], x)
    assert relative_error(dfdx.toarray(), numeric) < TOLERANCE
    linear, _, _ = deformed_sheet(np.random.default_rng(seed))[0].evaluate_forces(x, v, 0.0, int(T.STRETCH), False)
    assert np.linalg.norm(force - linear) > 0.1 * np.linalg.norm(linear)  # the random strains pass the knee


def test_biphasic_stretch_is_linear_below_the_knee_and_stiff_past_it() -> None:
    """A strip stretched along warp: force per unit width k s below the knee, k s + (r-1) k (s - knee) past it."""
    for strain, expected_factor in ((0.01, 0.01), (0.05, 0.05 + 11.0 * 0.03)):
        doc = sheet_shot("strip", 2, 2, 1.0, 1.0, plane="xz",
                         material={"stretch_warp": 1000.0, "stretch_weft": 1000.0, "shear": 0.0, "bend": 0.0, **BIPHASIC})
        scene, sim = make_sim(doc)
        x = scene.positions.copy()
        x[:, 0] *= 1.0 + strain  # warp (u) along x
        force, _, _ = sim.evaluate_forces(x, np.zeros_like(x), 0.0, int(T.STRETCH), False)
        force = np.asarray(force).reshape(-1, 3)
        right = x[:, 0] > 0.5 * x[:, 0].max()
        # The two right vertices carry the strip's tension, k * psi'(s) per metre of width (1 m).
        assert force[right, 0].sum() == pytest.approx(-1000.0 * expected_factor, rel=1e-9)


def test_biphasic_projected_stiffness_is_positive_semidefinite() -> None:
    sim, x, v = deformed_sheet(np.random.default_rng(7), **BIPHASIC)
    _, dfdx, _ = sim.evaluate_forces(x, v, 0.0, int(T.STRETCH), True)
    assert np.linalg.eigvalsh(-dfdx.toarray()).min() > -1e-8 * np.abs(dfdx.toarray()).max()
