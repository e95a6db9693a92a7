"""The material law a robot description asks for, with a per-tet small-strain modulus.

``[material] model = "neo-hookean"`` is today's foam law; ``"yeoh"`` is cast silicone
(:class:`~lab.fem.materials.YeohMaterial`). Every tool that changes the stiffness of a
robot (an as-built stiffness gradient, a calibrated softness, a per-tet modulus) speaks in
the small-strain Young's modulus E; a Yeoh law follows it by scaling all its coefficients
by E / E_nominal, which keeps its shape (the stiffening under strain) and its Poisson ratio.
"""

from __future__ import annotations

import numpy as np

from lab.fem.materials import NeoHookeanMaterial, YeohMaterial

__all__ = ["description_material"]


def description_material(robot, youngs_modulus_pa):
    """The description's material law with a (per-tet) small-strain modulus.

    A neo-Hookean robot takes ``youngs_modulus_pa`` as it is; a Yeoh robot scales its
    C10, C20, C30 (and bulk modulus) by ``youngs_modulus_pa / robot.youngs_modulus_pa``, so an
    as-built stiffness gradient or a fitted softness stiffens or softens the whole law alike.

    Parameters
    ----------
    robot : RobotDescription
        The description (``material_model``, its coefficients, ``poisson_ratio``).
    youngs_modulus_pa : float or ndarray, shape (M,)
        The small-strain Young's modulus, Pa (scalar or one per tet).

    Returns
    -------
    NeoHookeanMaterial or YeohMaterial
        The law, mesh-free.
    """
    if robot.material_model != "yeoh":
        return NeoHookeanMaterial(youngs_modulus_pa, robot.poisson_ratio)
    scale = np.asarray(youngs_modulus_pa, float) / robot.youngs_modulus_pa
    c10, c20, c30 = (scale * c for c in robot.yeoh_c_pa)
    if robot.bulk_modulus_pa is not None:
        return YeohMaterial(c10, c20, c30, bulk_modulus_pa=scale * robot.bulk_modulus_pa)
    return YeohMaterial(c10, c20, c30, poisson_ratio=robot.poisson_ratio)
