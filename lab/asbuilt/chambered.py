"""The as-built FEM of a robot driven by pressure chambers: moved cavities, re-meshed.

A defects file's ``[[chambers]]`` (:class:`~lab.asbuilt.fields.ChamberDefects`) says where
each cast cavity really is: its axis ``offset_error_m`` further out and ``angle_error_deg``
round the section, its radius ``radius_error_m`` larger (a core pin off its seat, a printed
core off size). :func:`as_built_chambers` moves the description's chambers so and checks
that the walls still hold (:func:`lab.description.chambers.check_chamber_geometry`,
refused naming the fields otherwise); :func:`as_built_chambered_fem` meshes the body with
the moved cavities by gmsh (:class:`lab.fem.bodies.ChamberedBody`) and scales the
description's Yeoh law per tet by the softness, the curing gradient
(as :func:`lab.asbuilt.arm.youngs_modulus_per_tet` does) and each chamber's ``stiffness``, applied
to the silicone round that chamber (:func:`chamber_stiffness_per_tet`). Gravity turns with
a tilted base as for the cable arms. Every field: ``docs/design/rig.md``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from lab.asbuilt.fields import Defects, DefectsError
from lab.description import RobotDescription
from lab.errors import InputError

__all__ = ["WALL_REACH", "as_built_chambers", "chamber_stiffness_per_tet", "as_built_chambered_fem"]

#: A chamber's ``stiffness`` applies to the silicone within this many cavity radii of its
#: axis (and as far beyond its ends): its wall, to about the designed wall thickness.
WALL_REACH = 2.0


def as_built_chambers(robot: RobotDescription, defects: Defects) -> tuple:
    """The description's chambers moved by the defects' cavity errors, their walls checked.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot (its ``chambers``, body and ``[mesh] size_m``).
    defects : Defects
        Its defects, one :class:`~lab.asbuilt.fields.ChamberDefects` per chamber.

    Returns
    -------
    tuple of Chamber
        The as-built chambers; DefectsError naming the chamber's fields when a moved cavity
        leaves the body, overlaps another or leaves a wall thinner than one element.
    """
    from lab.description.chambers import check_chamber_geometry

    if len(defects.chambers) != len(robot.chambers):
        raise DefectsError(f"[[chambers]] must have one table per chamber of {robot.name} ({len(robot.chambers)})")
    moved = tuple(
        dataclasses.replace(
            c,
            angle_deg=c.angle_deg + d.angle_error_deg,
            offset_m=c.offset_m + d.offset_error_m,
            radius_m=c.radius_m + d.radius_error_m,
        )
        for c, d in zip(robot.chambers, defects.chambers)
    )
    try:
        check_chamber_geometry(moved, robot.length_m, robot.radius_at, robot.body_shape.mesh_size_m)
    except InputError as err:
        raise DefectsError(
            f"fields 'chambers[].offset_error_m', 'angle_error_deg', 'radius_error_m' move a cavity too far: {err}"
        ) from None
    return moved


def chamber_stiffness_per_tet(chambers, factors, centroids_W: np.ndarray) -> np.ndarray:
    """Each tet's modulus factor (M,) from the chamber it surrounds (1 elsewhere).

    Parameters
    ----------
    chambers : sequence of Chamber
        The (as-built) chambers, with their cavity geometry.
    factors : sequence of float
        Each chamber's ``stiffness``.
    centroids_W : numpy.ndarray
        Tet centroids, shape (M, 3), m.

    Returns
    -------
    numpy.ndarray
        Factor per tet, shape (M,): that of the nearest chamber whose axis is within
        :data:`WALL_REACH` cavity radii (and whose ends are within as much), else 1.
    """
    c = np.asarray(centroids_W, float)
    out = np.ones(len(c))
    best = np.full(len(c), np.inf)
    for chamber, f in zip(chambers, factors):
        a = math.radians(chamber.angle_deg)
        axis = chamber.offset_m * np.array([math.cos(a), math.sin(a)])
        d = np.linalg.norm(c[:, 1:] - axis, axis=1)
        reach = WALL_REACH * chamber.radius_m
        near = (d <= reach) & (c[:, 0] >= chamber.start_m - reach) & (c[:, 0] <= chamber.end_m + reach) & (d < best)
        out[near], best[near] = float(f), d[near]
    return out


def as_built_chambered_fem(robot: RobotDescription, defects: Defects, *, n_rings=None, n_axial=None):
    """The FEM of an as-built robot driven by its pressure chambers.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot: a cylinder or tapered body with pressure chambers and no cables.
    defects : Defects
        Its defects (softness, gradient, ``[[chambers]]``, optional ``[mount]``).
    n_rings, n_axial : None
        Refused: a body with chambers is meshed by gmsh at the description's ``[mesh] size_m``.

    Returns
    -------
    ArmFEM
        The as-built FEM (the moved cavities, the per-tet Yeoh law, gravity turned by the
        tilt), its inputs the chambers' pressures (Pa).
    """
    from lab.fem.bodies import ChamberedBody
    from lab.fem.model import ArmFEM

    if robot.n_cables:
        raise DefectsError(
            f"robot {robot.name!r} has cables and chambers: as-built robots are emulated for cables alone or "
            "pressure chambers alone"
        )
    if n_rings is not None or n_axial is not None or defects.n_rings or defects.n_axial:
        raise DefectsError(
            f"robot {robot.name!r}: a body with chambers is meshed by gmsh at [mesh] size_m; [emulator] n_rings "
            "and n_axial are for the structured meshes of the cable arms"
        )
    if defects.law != "neo-hookean":
        raise DefectsError(f"[material] law = {defects.law!r}: a chambered robot keeps its description's law")
    built = dataclasses.replace(robot, chambers=as_built_chambers(robot, defects))
    if defects.R_tilt is not None:
        built = dataclasses.replace(built, gravity_m_s2=defects.R_tilt.T @ robot.gravity_m_s2)
    body = ChamberedBody(built)
    centroids = body.mesh.X_W[body.mesh.tets].mean(axis=1)
    s = np.clip(centroids @ defects.gradient_direction_W / robot.radius_m, -1.0, 1.0)  # as youngs_modulus_per_tet
    E = robot.youngs_modulus_pa * defects.softness * (1.0 + defects.gradient * s)
    E = E * chamber_stiffness_per_tet(built.chambers, [d.stiffness for d in defects.chambers], centroids)
    return ArmFEM(built, body=body, youngs_modulus_pa=E)
