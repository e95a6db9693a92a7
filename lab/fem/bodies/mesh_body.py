"""A body from a mesh or CAD file: the description's ``[body] shape = "mesh"``.

:class:`MeshBody` takes its rest mesh from
:func:`lab.description.geometry.read_body_mesh` (read and checked, cached), its clamped
nodes from :func:`~lab.description.geometry.clamped_nodes` (the base, or a physical group)
and embeds points with :func:`~lab.description.geometry.locate`.
"""

from __future__ import annotations

import numpy as np

from lab.description.geometry import clamped_nodes, locate, read_body_mesh
from lab.errors import InputError
from lab.fem.bodies.base import Body, Marker, register_body
from lab.fem.bodies.markers import body_markers
from lab.fem.bodies.mesh import TetMesh

__all__ = ["MeshBody"]


@register_body("mesh")
class MeshBody(Body):
    """The description's body file, clamped at its base or at a named group.

    Parameters
    ----------
    robot : RobotDescription
        Its ``body_shape`` (``shape = "mesh"``: file, unit, size, clamp), tip marker and markers.
    shape : BodyShape, optional
        Another body shape than ``robot.body_shape`` (same fields).
    """

    def __init__(self, robot, shape=None):
        self.robot = robot
        self.shape = robot.body_shape if shape is None else shape
        body_mesh = read_body_mesh(self.shape)
        self.groups = body_mesh.groups
        self.mesh = TetMesh(body_mesh.X_m, body_mesh.tets)
        self.clamped = clamped_nodes(body_mesh, self.shape)

    def markers(self) -> dict[str, Marker]:
        """The tip marker, then the description's markers (inside, or on stalks).

        Returns
        -------
        dict of str to Marker
            ``{"tip": ..., NAME: ...}`` in the description's order.
        """
        return body_markers(self, self.robot)

    def embed(self, points_W, what: str) -> tuple[np.ndarray, np.ndarray]:
        """Barycentric embedding of points (m) in the rest mesh, naming one outside.

        Parameters
        ----------
        points_W : array_like, shape (P, 3) or (3,)
            Points in frame W, m.
        what : str
            What the points are.

        Returns
        -------
        nodes, weights : ndarray, shape (P, 4)
            Each point's tet nodes and barycentric weights (non-negative, summing to 1).
        """
        points_W = np.atleast_2d(np.asarray(points_W, float))
        tet, w = locate(self.mesh.X_W, self.mesh.tets, points_W)
        outside = np.flatnonzero(tet < 0)
        if len(outside):
            i = int(outside[0])
            which = f"{what} {i} " if len(points_W) > 1 else f"{what} "
            raise InputError(
                f"{which}{np.round(points_W[i], 6).tolist()} m lies outside the body of {self.shape.mesh_file}: "
                "move it inwards in the description"
            )
        w = np.clip(w, 0.0, None)
        return self.mesh.tets[tet], w / w.sum(axis=1, keepdims=True)
