"""The mesh a command builds its FEM on: the robot description's, or overridden.

:class:`MeshSpec` is the one setting behind every ``--n-rings``/``--n-axial`` flag. Unset
fields keep the description's resolution; :meth:`MeshSpec.resolve` fills them in and
refuses, before any work, a mesh that is not positive or would not fit in memory
(:func:`lab.fem.bodies.mesh.check_mesh_size`).
"""

from __future__ import annotations

from dataclasses import dataclass

from lab.errors import FieldError
from lab.fem.bodies.mesh import TetMesh, check_mesh_size, cylinder_mesh
from lab.specs import Spec, option, positive_int

__all__ = ["MeshSpec"]


@dataclass(frozen=True)
class MeshSpec(Spec):
    """Mesh resolution overrides; ``None`` keeps the robot description's value.

    Attributes
    ----------
    n_rings : int or None
        Rings across the radius (>= 1).
    n_axial : int or None
        Layers along the length (>= 1).
    """

    n_rings: int | None = option(help="FEM mesh rings across the radius", type=int, check=positive_int)
    n_axial: int | None = option(help="FEM mesh layers along the length", type=int, check=positive_int)

    @property
    def is_default(self) -> bool:
        """True when neither field overrides the description."""
        return self.n_rings is None and self.n_axial is None

    def overrides(self) -> dict:
        """The set fields as keyword arguments.

        Returns
        -------
        dict of str to int
            ``n_rings`` and/or ``n_axial``, those that are not None.
        """
        return {k: v for k, v in (("n_rings", self.n_rings), ("n_axial", self.n_axial)) if v is not None}

    def resolve(self, robot) -> tuple[int, int]:
        """The resolution for ``robot``, checked to fit in memory (InputError if not).

        Parameters
        ----------
        robot : RobotDescription
            Gives the default ``n_rings`` and ``n_axial``.

        Returns
        -------
        n_rings, n_axial : int or None
            This spec's values where set, else the robot's; None for a body meshed from a file.
        """
        shape = getattr(robot, "body_shape", None)
        if shape is not None and shape.shape == "mesh":  # the mesh comes from the description's file
            for name in self.overrides():
                raise FieldError(
                    f"MeshSpec.{name} is not used by robot {robot.name!r}: its body is meshed from body.mesh_file "
                    "(set mesh.size_m there)"
                )
            return None, None
        if getattr(robot, "chambers", ()):  # gmsh meshes it around the cavities
            for name in self.overrides():
                raise FieldError(
                    f"MeshSpec.{name} is not used by robot {robot.name!r}: its body has chambers and is meshed by "
                    "gmsh at mesh.size_m (set it there)"
                )
            return None, None
        n_rings = robot.n_rings if self.n_rings is None else self.n_rings
        n_axial = robot.n_axial if self.n_axial is None else self.n_axial
        check_mesh_size(n_rings, n_axial)
        return n_rings, n_axial

    def mesh(self, robot) -> TetMesh:
        """The structured cylinder mesh of ``robot`` at the resolved resolution.

        Parameters
        ----------
        robot : RobotDescription
            Gives ``length_m``, ``radius_m`` (m) and the default resolution.

        Returns
        -------
        TetMesh
            The :func:`~lab.fem.bodies.mesh.cylinder_mesh` (or, for a tapered body,
            :func:`~lab.fem.bodies.tapered.tapered_mesh`) of the resolution ``resolve`` gives, in frame W.
        """
        n_rings, n_axial = self.resolve(robot)
        shape = getattr(robot, "body_shape", None)
        if shape is not None and shape.shape == "tapered":
            from lab.fem.bodies.tapered import tapered_mesh

            return tapered_mesh(shape.profile_m, n_rings, n_axial)
        return cylinder_mesh(robot.length_m, robot.radius_m, n_rings, n_axial)


def mesh_label(robot, n_rings, n_axial) -> str:
    """How a run's log names the FEM mesh of ``robot``.

    Parameters
    ----------
    robot : RobotDescription
        The description.
    n_rings, n_axial : int or None
        The structured mesher's resolution (None for a body meshed by gmsh or read from a file).

    Returns
    -------
    str
        ``"n_rings=3 n_axial=20"``, ``"from body.mesh_file"`` or ``"by gmsh at size_m=0.005 around 3
        chamber(s)"``.
    """
    if n_rings is not None:
        return f"n_rings={n_rings} n_axial={n_axial}"
    shape = getattr(robot, "body_shape", None)
    if shape is None or shape.shape == "mesh":
        return "from body.mesh_file"
    return f"by gmsh at size_m={shape.mesh_size_m:g} around {len(robot.chambers)} chamber(s)"
