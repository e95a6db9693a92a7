"""Bodies: the tet mesh the FEM deforms, its clamped nodes and its markers.

:class:`Body` is the interface (:mod:`.base`); the description's bodies are the structured
cylinder (:class:`CylinderBody`), the tapered solid of revolution (:class:`TaperedBody`),
either with chambers' cavities cut out by gmsh (:class:`ChamberedBody`) and the mesh or
CAD file (:class:`MeshBody`), and :func:`body_of` picks the one a description asks for;
:func:`chamber_surface` gives a chamber's cavity wall from a body's node group. Meshes,
meshing and embedding live in :mod:`.mesh` and :mod:`.tapered`, markers inside the body or
on stalks in :mod:`lab.fem.bodies.markers`, the resolution setting of every command in
:mod:`.mesh_spec`. A new body is one module with a
:class:`Body` subclass decorated with :func:`register_body`.
"""

from lab.errors import InputError
from lab.fem.bodies.base import BODIES, Body, FreeCoordinates, Marker, register_body
from lab.fem.bodies.chamber_walls import chamber_surface
from lab.fem.bodies.chambered import ChamberedBody
from lab.fem.bodies.cylinder import CylinderBody
from lab.fem.bodies.mesh import TetMesh, barycentric, cylinder_mesh, load_mesh, save_mesh
from lab.fem.bodies.mesh_body import MeshBody
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.fem.bodies.tapered import TaperedBody, tapered_mesh


def body_of(robot, *, n_rings=None, n_axial=None) -> Body:
    """The body a description asks for (``robot.body_shape.shape``).

    Parameters
    ----------
    robot : RobotDescription
        The description.
    n_rings, n_axial : int, optional
        Override the structured mesh's resolution (cylinder and tapered bodies without
        chambers; a mesh body and a body with chambers, meshed by gmsh, take none).

    Returns
    -------
    Body
        A :class:`CylinderBody`, :class:`TaperedBody`, :class:`ChamberedBody` (a cylinder
        or tapered body with ``robot.chambers``) or :class:`MeshBody`.
    """
    shape = getattr(robot, "body_shape", None)
    kind = "cylinder" if shape is None else shape.shape
    if kind in ("cylinder", "tapered") and getattr(robot, "chambers", ()):
        if n_rings is not None or n_axial is not None:
            raise InputError(
                f"robot {robot.name!r}: a body with chambers is meshed by gmsh at [mesh] size_m; n_rings and n_axial "
                "are for the structured cylinder and tapered meshes"
            )
        return ChamberedBody(robot)
    if kind == "cylinder":
        return CylinderBody(robot, n_rings=n_rings, n_axial=n_axial)
    if kind == "tapered":
        return TaperedBody(robot, n_rings=n_rings, n_axial=n_axial)
    if kind == "mesh":
        if n_rings is not None or n_axial is not None:
            raise InputError(
                f"robot {robot.name!r}: a mesh body takes its mesh from body.mesh_file; n_rings and n_axial are "
                "for cylinder and tapered bodies"
            )
        return MeshBody(robot)
    raise InputError(f"robot {robot.name!r}: unknown body shape {kind!r}")


__all__ = [
    "BODIES",
    "Body",
    "ChamberedBody",
    "CylinderBody",
    "FreeCoordinates",
    "Marker",
    "MeshBody",
    "MeshSpec",
    "TaperedBody",
    "TetMesh",
    "barycentric",
    "body_of",
    "chamber_surface",
    "cylinder_mesh",
    "load_mesh",
    "register_body",
    "save_mesh",
    "tapered_mesh",
]
