"""The as-built arm: a defect file the nominal model does not know, and its statics.

A *defects file* (TOML, user-editable) says how the robot that was actually built
differs from its description (``[material]`` softness, casting gradient and optionally
the hyperfoam law, ``[[cables]]`` eyelet shifts, slack, play and optionally stiffness,
an optional ``[mount]`` tilt) and how the emulated rig (``twin``) behaves in time
(``[lag]`` with an optional creep mode, ``[motors]``, ``[mocap]`` with an optional frame
registration error; ``[emulator]`` an optional FEM mesh). :func:`load_defects` validates
every field (:mod:`lab.asbuilt.parse`; meanings and ranges in
:mod:`lab.asbuilt.fields`) and raises :class:`DefectsError` naming the file and the
bad field; the shipped default for a robot is ``lab/rig/defects/<robot>.toml``.
:func:`as_built_fem` is the FEM of the as-built arm, solved in the body frame (gravity
turned by the tilt; where the motion capture sees the tip is :class:`AsBuiltBody`'s
business), and :class:`EquilibriumCache` solves it for effective cable contractions,
warm-started from the nearest cached equilibrium. Every field: ``docs/design/rig.md``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from lab.asbuilt.equilibria import EquilibriumCache
from lab.asbuilt.fields import CableDefects, Defects, DefectsError
from lab.asbuilt.parse import DEFECTS_FIELDS, FORMAT_VERSION, parse_defects
from lab.description import RobotDescription, read_toml
from lab.errors import InputError
from lab.fem.actuators.cable_routes import route_hessian, series_stiffness, spring
from lab.fem.bodies import body_of
from lab.fem.bodies.mesh import cylinder_mesh
from lab.fem.materials.hyperfoam import HyperfoamMaterial
from lab.fem.model import ArmFEM

__all__ = [
    "FORMAT_VERSION",
    "DEFECTS_DIR",
    "DEFECTS_FIELDS",
    "CableDefects",
    "Defects",
    "DefectsError",
    "parse_defects",
    "default_defects_path",
    "load_defects",
    "as_built_robot",
    "youngs_modulus_per_tet",
    "hyperfoam_mu_per_tet",
    "as_built_fem",
    "SeriesCableFEM",
    "EquilibriumCache",
]

#: The shipped defects files (package data of ``lab.rig``, where the twin rig reads them by default).
DEFECTS_DIR = Path(__file__).resolve().parent.parent / "rig" / "defects"


def default_defects_path(robot: RobotDescription) -> Path:
    """The shipped defects file of ``robot``: ``lab/rig/defects/<robot.name>.toml``.

    Parameters
    ----------
    robot : RobotDescription
        The robot (its name names the file).

    Returns
    -------
    Path
        The file's absolute path (which may not exist).
    """
    return DEFECTS_DIR / f"{robot.name}.toml"


def load_defects(path: str | Path | None, robot: RobotDescription) -> Defects:
    """Load and validate a defects file.

    Parameters
    ----------
    path : str or Path or None
        The TOML file; None: the shipped default for ``robot`` (DefectsError if none).
    robot : RobotDescription
        The robot the file must fit (name, cables).

    Returns
    -------
    Defects
        The validated defects, recording the path (relative to the repository for a
        shipped file).
    """
    shown = None
    if path is None:
        path = default_defects_path(robot)
        if not path.exists():
            raise DefectsError(
                f"no shipped defects file for robot {robot.name!r} ({path}); "
                f"write one and name it as the rig twin:DEFECTS.toml"
            )
        shown = f"lab/rig/defects/{path.name}"  # recorded relative to the repository
    path = Path(path)
    data = read_toml(path, DefectsError, "defects file")
    try:
        return parse_defects(data, robot, shown or str(path))
    except DefectsError as err:
        raise DefectsError(f"{path}: {err}") from None


def as_built_robot(robot: RobotDescription, defects: Defects) -> RobotDescription:
    """The description with every cable's via points moved by its ``via_shift_m``."""
    cables = tuple(
        dataclasses.replace(c, via_points_m=c.via_points_m + d.via_shift_m)
        for c, d in zip(robot.cables, defects.cables)
    )
    for i, c in enumerate(cables):
        r = np.hypot(c.via_points_m[:, 1], c.via_points_m[:, 2])
        if (
            np.any(r > robot.radius_at(c.via_points_m[:, 0]))
            or np.any(c.via_points_m[:, 0] <= 0)
            or np.any(c.via_points_m[:, 0] > robot.length_m)
            or np.any(np.diff(c.via_points_m[:, 0]) <= 0)
        ):
            raise DefectsError(
                f"field 'cables[{i}].via_shift_m' moves eyelets of {c.name!r} out of the body "
                f"(radius {robot.radius_m} m or the profile's, 0 < x <= {robot.length_m} m, increasing x)"
            )
    return dataclasses.replace(robot, cables=cables)


def youngs_modulus_per_tet(robot: RobotDescription, defects: Defects, tet_centroids_W: np.ndarray) -> np.ndarray:
    """As-built Young's modulus (M,) Pa of tets with centroids (M, 3) m."""
    s = np.clip(tet_centroids_W @ defects.gradient_direction_W / robot.radius_m, -1.0, 1.0)
    return robot.youngs_modulus_pa * defects.softness * (1.0 + defects.gradient * s)


def hyperfoam_mu_per_tet(robot: RobotDescription, defects: Defects, tet_centroids_W: np.ndarray) -> np.ndarray:
    """As-built initial shear modulus (M,) Pa of the hyperfoam law: ``hyperfoam_mu_pa``
    scaled per tet by softness and gradient as :func:`youngs_modulus_per_tet` scales E."""
    s = np.clip(tet_centroids_W @ defects.gradient_direction_W / robot.radius_m, -1.0, 1.0)
    return defects.hyperfoam_mu_pa * defects.softness * (1.0 + defects.gradient * s)


def _elastic_args(robot: RobotDescription, defects: Defects, centroids_W: np.ndarray) -> dict:
    """ArmFEM's material arguments: the per-tet modulus, or the hyperfoam law."""
    if defects.law != "hyperfoam":
        return {"youngs_modulus_pa": youngs_modulus_per_tet(robot, defects, centroids_W)}
    mu = hyperfoam_mu_per_tet(robot, defects, centroids_W)
    try:
        return {"material": HyperfoamMaterial(mu, defects.hyperfoam_alpha, defects.hyperfoam_beta)}
    except InputError as err:  # a value the parser allows but the law does not take
        where = f"{defects.path}: " if defects.path else ""
        raise DefectsError(f'{where}[material] law = "hyperfoam": {err}') from None


def as_built_fem(
    robot: RobotDescription, defects: Defects, *, n_rings: int | None = None, n_axial: int | None = None
) -> ArmFEM:
    """The FEM of the as-built arm (moved eyelets, softer graded foam -- neo-Hookean, or the
    hyperfoam law of :mod:`lab.fem.materials.hyperfoam` --, slack cables; gravity ``R_tilt^T g`` in the
    body frame of a tilted base; stretching cables in series).

    Mesh resolution: the arguments, else the defects file's ``[emulator]``, else the
    description's. Without the optional defects this is exactly the FEM it always was.
    A tapered or mesh body is the description's (:func:`lab.fem.bodies.body_of`; the
    gradient's normalising radius stays ``radius_m``). A tension-controlled tendon holds
    its tension whatever its length: its ``slack_m`` and ``play_m`` are not emulated, and a
    cable ``stiffness_n_per_m`` is refused on a robot with such tendons. A robot with
    pressure chambers is :func:`lab.asbuilt.chambered.as_built_chambered_fem`'s."""
    if getattr(robot, "chambers", ()):  # cast cavities, re-meshed by gmsh
        from lab.asbuilt.chambered import as_built_chambered_fem

        return as_built_chambered_fem(robot, defects, n_rings=n_rings, n_axial=n_axial)
    built = as_built_robot(robot, defects)
    if defects.R_tilt is not None:
        built = dataclasses.replace(built, gravity_m_s2=defects.R_tilt.T @ robot.gravity_m_s2)
    n_rings = n_rings or defects.n_rings or robot.n_rings
    n_axial = n_axial or defects.n_axial or robot.n_axial
    k_cable = [np.inf if c.stiffness_n_per_m is None else c.stiffness_n_per_m for c in defects.cables]
    slack = defects.slack_m
    if not robot.all_angle:
        if not np.all(np.isinf(k_cable)):
            raise DefectsError(
                "field 'cables[].stiffness_n_per_m' is emulated for robots whose cables are all "
                "angle-controlled; remove it (a tension-controlled tendon's stretch does not change its tension)"
            )
        slack = np.array([s_ for s_, c in zip(slack, robot.cables) if c.control == "angle"])
    shape = getattr(robot.body_shape, "shape", "cylinder")
    if shape == "cylinder":
        body, mesh = None, cylinder_mesh(robot.length_m, robot.radius_m, n_rings, n_axial)
        tet_mesh = mesh
    else:
        res = {} if shape == "mesh" else {"n_rings": n_rings, "n_axial": n_axial}
        body, mesh = body_of(built, **res), None
        tet_mesh = body.mesh
    centroids = tet_mesh.X_W[tet_mesh.tets].mean(axis=1)
    kw = dict(_elastic_args(robot, defects, centroids), cable_slack_m=slack)
    if body is not None:
        kw["body"] = body
    try:
        if np.all(np.isinf(k_cable)):
            return ArmFEM(built, mesh, **kw)
        return SeriesCableFEM(built, mesh, cable_own_stiffness_n_per_m=k_cable, **kw)
    except ValueError as err:  # an eyelet between the polygonal mesh boundary and the radius
        raise DefectsError(
            f"as-built eyelets do not fit the {n_rings}-ring mesh, whose polygonal section "
            f"is smaller than the radius: {err}; shift them less, or use more rings"
        ) from None


class SeriesCableFEM(ArmFEM):
    """:class:`~lab.fem.model.ArmFEM` whose cables stretch: cable c's own stiffness
    ``cable_own_stiffness_n_per_m[c]`` (N/m; ``inf``: inextensible) in series with the
    description's spring, so it pulls with ``cable_k_n_per_m[c]`` (m,) N/m =
    :func:`~lab.fem.actuators.cable_routes.series_stiffness`. Every derivative stays exact: the
    springs' tensions and stiffnesses scale with k, and its Hessian
    (:meth:`~lab.fem.model.ArmFEM.hessian`, and the line search's one pass) adds
    ``(k_eff - k)`` times each cable's unit-stiffness block to ArmFEM's (which loops over the
    cables one stretch at a time, at the description's k)."""

    def __init__(self, robot: RobotDescription, mesh, *, cable_own_stiffness_n_per_m, **kw):
        super().__init__(robot, mesh, **kw)
        self.cable_k_n_per_m = series_stiffness(robot.cable_stiffness_n_m, cable_own_stiffness_n_per_m)
        dof_to_free = np.full(3 * self.mesh.n_nodes, -1)
        dof_to_free[self.free_dofs] = np.arange(self.n_free)
        self._block_free = []  # per cable: (its block's rows kept, their free coordinates)
        for c in self.cables:
            f = dof_to_free[3 * c.nodes.ravel()[:, None] + np.arange(3)].ravel()
            keep = np.flatnonzero(f >= 0)
            self._block_free.append((keep, f[keep]))
        self._slots = None  # per cable: where its block's entries sit in the Hessian's data

    def cable_springs(self, stretch_m):
        """Energy (J), tension (N), stiffness (N/m) of every cable (m,) at stretches (m,) m;
        a single stretch (ArmFEM.hessian's per-cable loop) at the description's k."""
        d = np.asarray(stretch_m, dtype=float)
        if d.ndim == 0:
            return super().cable_springs(d)
        return spring(d, self.cable_k_n_per_m, self.robot.slack_smoothing_m)

    def _corrected(self, H: sp.csr_matrix, x: np.ndarray, u_motor) -> sp.csr_matrix:
        """ArmFEM's Hessian ``H`` (n_free, n_free) at nodes ``x``, plus each cable's series
        correction added in place (the sparsity pattern, and so the solver's symbolic
        analysis, is unchanged)."""
        if self._slots is None:
            keys = np.repeat(np.arange(self.n_free), np.diff(H.indptr)) * self.n_free + H.indices
            self._slots = []
            for _, f in self._block_free:
                want = (f[:, None] * self.n_free + f[None, :]).ravel()
                slot = np.searchsorted(keys, want)
                if np.any(slot >= len(keys)) or np.any(keys[np.minimum(slot, len(keys) - 1)] != want):
                    raise AssertionError("SeriesCableFEM: a cable block outside the Hessian's pattern")
                self._slots.append(slot)
        dk = self.cable_k_n_per_m - self.robot.cable_stiffness_n_m
        eps = self.robot.slack_smoothing_m
        for c, L_star, dk_c, (keep, _), slot in zip(
            self.cables, self.cable_targets(u_motor), dk, self._block_free, self._slots
        ):
            if dk_c != 0.0:
                block = dk_c * route_hessian(c, x, L_star, 1.0, eps)
                H.data += np.bincount(slot, weights=block[np.ix_(keep, keep)].ravel(), minlength=len(H.data))
        return H
