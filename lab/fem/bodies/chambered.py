"""A cylinder or tapered body with fluid chambers: the description's cavities cut out by gmsh.

:class:`ChamberedBody` takes its rest mesh from
:func:`lab.description.chambered.chambered_body_mesh` (the solid less each chamber's
cylindrical cavity, meshed with linear tets of ``[mesh] size_m``, cached), clamps the nodes
of its base face (the ``"base"`` group) and keeps the node groups of the cavities' walls in
``groups`` by chamber name, from which :func:`~lab.fem.bodies.chamber_walls.chamber_surface`
takes each chamber's closed surface. Points are embedded with
:func:`~lab.description.geometry.locate`; a point in a cavity lies outside the body.
"""

from __future__ import annotations

import numpy as np

from lab.description.chambered import chambered_body_mesh
from lab.description.geometry import locate
from lab.errors import InputError
from lab.fem.bodies.base import Body, Marker, register_body
from lab.fem.bodies.markers import body_markers
from lab.fem.bodies.mesh import TetMesh

__all__ = ["ChamberedBody"]


@register_body("chambered")
class ChamberedBody(Body):
    """The description's cylinder or tapered body less its chambers' cavities, base clamped.

    Parameters
    ----------
    robot : RobotDescription
        Its ``body_shape`` (``"cylinder"`` or ``"tapered"``, ``mesh_size_m``),
        ``length_m``, ``radius_m``, ``chambers``, tip marker and markers.
    chambers : sequence of Chamber, optional
        The chambers instead of ``robot.chambers``.
    shape : BodyShape, optional
        Another body shape than ``robot.body_shape``.
    size_m : float, optional
        The element size instead of the shape's ``mesh_size_m``, m.
    """

    def __init__(self, robot, chambers=None, *, shape=None, size_m=None):
        self.robot = robot
        self.shape = robot.body_shape if shape is None else shape
        self.chambers = tuple(getattr(robot, "chambers", ()) if chambers is None else chambers)
        size_m = self.shape.mesh_size_m if size_m is None else size_m
        if size_m is None:
            raise InputError(
                f"robot {robot.name!r}: a body with chambers is meshed by gmsh and needs the element size "
                "[mesh] size_m (m)"
            )
        body_mesh = chambered_body_mesh(self.shape, robot.length_m, robot.radius_m, self.chambers, size_m)
        self.size_m = float(size_m)
        self.groups = body_mesh.groups
        self.mesh = TetMesh(body_mesh.X_m, body_mesh.tets)
        self.clamped = np.zeros(self.mesh.n_nodes, bool)
        self.clamped[body_mesh.groups["base"]] = True

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
            Each point's tet nodes and barycentric weights (non-negative, summing to 1);
            InputError naming a point outside the body or in a cavity.
        """
        points_W = np.atleast_2d(np.asarray(points_W, float))
        tet, w = locate(self.mesh.X_W, self.mesh.tets, points_W)
        outside = np.flatnonzero(tet < 0)
        if len(outside):
            i = int(outside[0])
            which = f"{what} {i} " if len(points_W) > 1 else f"{what} "
            names = ", ".join(repr(c.name) for c in self.chambers)
            raise InputError(
                f"{which}{np.round(points_W[i], 6).tolist()} m lies outside the body, or in the cavity of a chamber "
                f"({names}): move it into the material in the description"
            )
        w = np.clip(w, 0.0, None)
        return self.mesh.tets[tet], w / w.sum(axis=1, keepdims=True)
