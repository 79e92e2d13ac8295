"""Material presets: named starting points for `material` (`{"preset": "denim", ...}`).

A preset fills the fields a piece's material leaves out; fields given beside it win. Each
preset says where its numbers come from, and whether they were measured:

- **measured**: Wang, O'Brien & Ramamoorthi 2011, "Data-Driven Elastic Models for Cloth:
  Modeling and Measurement" (SIGGRAPH), as distributed in ARCSim's `materials/*.json` (areal
  density in kg/m^2; stretching samples in N/m for the energy
  ``A/2 (k0 G00^2 + k2 G11^2 + 2 k1 G00 G11 + k3 G01^2)`` with G the Green strain, row 0 at
  zero strain, rows 1-5 at a principal stretch of 1 + 1/6 over five bias angles; bending
  samples in N m, three bias angles by five curvatures). Mapped to weft's energies (forces.h):
  ``stretch_warp = k0``, ``stretch_weft = k2`` (for small strain |w| - 1 = G), ``shear = k3 / 4``
  (weft's shear condition w_u . w_v is 2 G01), ``bend = ke / 12`` with ke the mean of the three
  bias angles' smallest-curvature samples (ARCSim's hinge energy is
  ``ke |e|^2 theta^2 / (8 (A0 + A1))``, weft's ``k 3 |e|^2 theta^2 / (2 (A0 + A1))``). Both measured presets are at most 1.11x their zero-strain
  stiffness at 1/6 stretch (mean of the five bias angles, per direction), so they are linear.
- **estimate**: no measured set was found for the fabric; the values are weft's estimates and
  say what they rest on. Treat them as a look to start from, not as data.

`docs/materials.md` lists the presets with their derivation; `weft materials` prints them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

PresetName = Literal["cotton", "denim", "silk", "leather"]

# The fields a preset may set (the rest of `Material`, thickness and friction included, keep
# their own defaults unless the shot gives them: they are contact settings, not the fabric's).
PRESET_FIELDS = ("density", "stretch_warp", "stretch_weft", "shear", "bend")


@dataclass(frozen=True)
class MaterialPreset:
    name: str
    fabric: str
    measured: bool
    source: str
    values: dict[str, float] = field(default_factory=dict)


def _wang2011(name: str, fabric: str, sample: str, density: float, stretch: tuple[float, float, float],
              bend_samples: tuple[float, float, float]) -> MaterialPreset:
    """A preset from one Wang 2011 fabric: density, the zero-strain stretching row (k0, k2, k3)
    and the three smallest-curvature bending samples (ARCSim's ke), in weft's energies."""
    k0, k2, k3 = stretch
    values = {"density": density, "stretch_warp": k0, "stretch_weft": k2, "shear": k3 / 4.0,
              "bend": round(sum(bend_samples) / 3.0 / 12.0, 10)}
    return MaterialPreset(
        name, fabric, True,
        f"Wang, O'Brien & Ramamoorthi 2011, measured sample '{sample}' (ARCSim materials/{sample}.json): "
        f"density {density} kg/m^2; zero-strain stretching k0 {k0}, k2 {k2}, k3 {k3} N/m; bending "
        f"ke {', '.join(f'{b:.3g}' for b in bend_samples)} N m at the smallest curvature",
        values,
    )


PRESETS: dict[str, MaterialPreset] = {
    "cotton": _wang2011("cotton", "woven cotton-rich twill, trousers weight (65% cotton, 35% polyester)",
                        "royal-target", 0.220, (2016.55456, 2034.97644, 104.759674),
                        (125.409805e-6, 107.997696e-6, 125.409805e-6)),
    "denim": _wang2011("denim", "11 oz denim, jeans (99% cotton, 1% spandex)", "11oz-black-denim", 0.324,
                       (205.352005, 1013.88629, 53.387184),
                       (64.196457e-6, 73.384567e-6, 96.951576e-6)),
    "silk": MaterialPreset(
        "silk", "silk charmeuse, 19 momme", False,
        "estimate: density from the fabric weight (19 momme x 4.34 g/m^2 per momme = 0.0825 kg/m^2); stretch "
        "and shear those of the measured cotton scaled by the weight ratio (a thinner woven of similar yarn "
        "strength per weight); bend 1/40 of the cotton's (a fluid drape), no measurement behind it",
        {"density": 0.0825, "stretch_warp": 760.0, "stretch_weft": 760.0, "shear": 9.8, "bend": 2.5e-7},
    ),
    "leather": MaterialPreset(
        "leather", "garment leather, about 1 mm", False,
        "estimate: density from a 1.0 mm hide at about 850 kg/m^3 (0.85 kg/m^2); stretch and shear chosen "
        "stiffer than the measured cotton and bend about 5x the measured denim's (a firm drape that folds in "
        "large panels), no measurement behind them",
        {"density": 0.85, "stretch_warp": 5000.0, "stretch_weft": 5000.0, "shear": 500.0, "bend": 3.0e-5},
    ),
}


def apply_preset(data: Any) -> Any:
    """A material document with its preset's values under the fields it gives (used by
    `Material`'s validator before field validation). Anything else is returned as it is: an
    unknown preset name is then reported by the field's own check."""
    if not isinstance(data, dict):
        return data
    preset = PRESETS.get(data.get("preset")) if isinstance(data.get("preset"), str) else None
    if preset is None:
        return data
    return {**preset.values, **data}
