"""The ``[material]`` table: a neo-Hookean foam or a Yeoh silicone, checked field by field.

``model = "neo-hookean"`` takes ``youngs_modulus_pa`` and ``poisson_ratio`` (today's foam
arms). ``model = "yeoh"`` takes ``yeoh_c10_pa`` (> 0), ``yeoh_c20_pa``, ``yeoh_c30_pa`` (Pa,
default 0) and either ``poisson_ratio`` (small strain, [0, 0.5)) or ``bulk_modulus_pa``, the
law of cast silicone (Ecoflex, Dragon Skin). Both take ``density_kg_m3`` and the optional
as-built ``stiffness_gradient``. A Yeoh material also reports its small-strain match, the
Young's modulus E = 4 C10 (1 + nu) and Poisson ratio nu (from the bulk modulus when that is
given), which the tools that only know a linear material use (as-built families, drawing).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.description.fields import get, refuse_unused, vec3
from lab.description.robot import DescriptionError

#: A Yeoh C10 outside this range (Pa) is taken for a unit error: soft silicones have
#: C10 from a few kPa (Ecoflex 00-10) to about a MPa (stiff Dragon Skin, Sylgard).
YEOH_C10_PLAUSIBLE_PA = (100.0, 1e7)


@dataclass(frozen=True)
class Material:
    """A parsed ``[material]``: the model, its small-strain match and its density.

    Attributes
    ----------
    model : str
        ``"neo-hookean"`` or ``"yeoh"``.
    youngs_modulus_pa, poisson_ratio : float
        The (small-strain) Young's modulus, Pa, and Poisson ratio.
    density_kg_m3 : float
        Density, kg/m^3.
    stiffness_gradient : ndarray, shape (3,)
        The as-built gradient [0, g_y, g_z].
    yeoh_c_pa : tuple of float or None
        (C10, C20, C30), Pa, for a Yeoh material.
    bulk_modulus_pa : float or None
        The Yeoh law's bulk modulus when given instead of the Poisson ratio, Pa.
    """

    model: str
    youngs_modulus_pa: float
    poisson_ratio: float
    density_kg_m3: float
    stiffness_gradient: np.ndarray
    yeoh_c_pa: tuple | None = None
    bulk_modulus_pa: float | None = None


def parse_material(mat: dict) -> Material:
    """Check a ``[material]`` table.

    Parameters
    ----------
    mat : dict
        The table (its field names already checked).

    Returns
    -------
    Material
    """
    model = mat.get("model")
    rho = get(mat, "density_kg_m3", "material", positive=True)
    grad = vec3(mat, "stiffness_gradient", "material") if "stiffness_gradient" in mat else np.zeros(3)
    if grad[0] != 0 or np.hypot(grad[1], grad[2]) >= 1:
        raise DescriptionError(
            f"field 'material.stiffness_gradient' must be [0, g_y, g_z], |g| < 1, got {grad.tolist()}"
        )
    if model == "neo-hookean":
        yeoh = ("yeoh_c10_pa", "yeoh_c20_pa", "yeoh_c30_pa", "bulk_modulus_pa")
        refuse_unused(mat, yeoh, "material", 'by model = "neo-hookean"')
        E = get(mat, "youngs_modulus_pa", "material", positive=True)
        nu = get(mat, "poisson_ratio", "material")
        if not -1.0 < nu < 0.5:
            raise DescriptionError(f"field 'material.poisson_ratio' must be in (-1, 0.5), got {nu}")
        return Material(model, E, nu, rho, grad)
    if model != "yeoh":
        raise DescriptionError(f'field \'material.model\' must be "neo-hookean" or "yeoh", got {model!r}')
    refuse_unused(mat, ("youngs_modulus_pa",), "material", 'by model = "yeoh" (give yeoh_c10_pa)')
    c10 = get(mat, "yeoh_c10_pa", "material", positive=True)
    lo, hi = YEOH_C10_PLAUSIBLE_PA
    if not lo <= c10 <= hi:
        raise DescriptionError(
            f"field 'material.yeoh_c10_pa' = {c10} Pa is implausible for a silicone (expected {lo:g} to {hi:g} Pa); "
            "is it in pascals?"
        )
    c20 = get(mat, "yeoh_c20_pa", "material") if "yeoh_c20_pa" in mat else 0.0
    c30 = get(mat, "yeoh_c30_pa", "material") if "yeoh_c30_pa" in mat else 0.0
    for key, c in (("yeoh_c20_pa", c20), ("yeoh_c30_pa", c30)):
        if abs(c) > 10 * c10:
            raise DescriptionError(f"field 'material.{key}' = {c} Pa is implausible beside yeoh_c10_pa = {c10} Pa")
    mu = 2 * c10
    if ("poisson_ratio" in mat) == ("bulk_modulus_pa" in mat):
        raise DescriptionError("give exactly one of 'material.poisson_ratio' and 'material.bulk_modulus_pa' for yeoh")
    if "poisson_ratio" in mat:
        nu, bulk = get(mat, "poisson_ratio", "material"), None
        if not 0.0 <= nu < 0.5:
            raise DescriptionError(f"field 'material.poisson_ratio' must be in [0, 0.5) for yeoh, got {nu}")
    else:
        bulk = get(mat, "bulk_modulus_pa", "material", positive=True)
        if bulk < mu:
            raise DescriptionError(
                f"field 'material.bulk_modulus_pa' = {bulk} Pa is below the shear modulus 2 C10 = {mu} Pa; "
                "silicone is nearly incompressible"
            )
    E, nu = yeoh_small_strain(c10, nu if bulk is None else None, bulk)
    return Material("yeoh", E, nu, rho, grad, (c10, c20, c30), bulk)


def yeoh_small_strain(c10_pa: float, poisson_ratio: float | None = None, bulk_modulus_pa: float | None = None):
    """Young's modulus and Poisson's ratio of a Yeoh law's small-strain limit.

    The shear modulus is mu = 2 C10; Poisson's ratio is given, or follows from the bulk
    modulus K as (3K - 2 mu) / (2 (3K + mu)); E = 2 mu (1 + nu). Whatever scales a Yeoh law
    (a calibration's softness) derives E here too, so a description written to TOML reads
    back bit for bit.

    Parameters
    ----------
    c10_pa : float
        C10, Pa.
    poisson_ratio : float, optional
        nu; give it or ``bulk_modulus_pa``.
    bulk_modulus_pa : float, optional
        K, Pa.

    Returns
    -------
    tuple of float
        (E in Pa, nu).
    """
    mu = 2 * c10_pa
    if bulk_modulus_pa is not None:
        poisson_ratio = (3 * bulk_modulus_pa - 2 * mu) / (2 * (3 * bulk_modulus_pa + mu))
    return float(2 * mu * (1 + poisson_ratio)), float(poisson_ratio)
