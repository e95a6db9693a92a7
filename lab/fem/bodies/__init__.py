"""Bodies: the tet mesh the FEM deforms, its clamped nodes and its markers.

:class:`Body` is the interface (:mod:`.base`), :class:`CylinderBody` the description's
structured cylinder (:mod:`.cylinder`); meshes, meshing and embedding live in
:mod:`.mesh`, the resolution setting of every command in :mod:`.mesh_spec`. A new body is
one module with a :class:`Body` subclass decorated with :func:`register_body`.
"""

from lab.fem.bodies.base import BODIES, Body, FreeCoordinates, Marker, register_body
from lab.fem.bodies.cylinder import CylinderBody
from lab.fem.bodies.mesh import TetMesh, barycentric, cylinder_mesh, load_mesh, save_mesh
from lab.fem.bodies.mesh_spec import MeshSpec

__all__ = [
    "BODIES",
    "Body",
    "CylinderBody",
    "FreeCoordinates",
    "Marker",
    "MeshSpec",
    "TetMesh",
    "barycentric",
    "cylinder_mesh",
    "load_mesh",
    "register_body",
    "save_mesh",
]
