"""The structured cylinder of a robot description, clamped at its base, with its tip marker.

The body every description has today: ``lab.fem.bodies.mesh.robot_mesh`` (or a given
mesh), the nodes of the base face x = min clamped, and the description's tip marker
``p_tip_marker_W`` as the marker ``"tip"``, then its ``markers`` (:mod:`lab.fem.bodies.markers`).
"""

from __future__ import annotations

import numpy as np

from lab.fem.bodies.base import Body, Marker, register_body
from lab.fem.bodies.markers import body_markers, embed_points
from lab.fem.bodies.mesh import TetMesh, robot_mesh


@register_body("cylinder")
class CylinderBody(Body):
    """The description's cylinder along +x, base face clamped.

    Parameters
    ----------
    robot : RobotDescription
        Its ``length_m``, ``radius_m``, mesh resolution and ``p_tip_marker_W`` (m).
    mesh : TetMesh, optional
        A mesh instead of the description's structured one.
    n_rings, n_axial : int, optional
        Override the description's resolution (without ``mesh``).
    clamp_tol_m : float
        Nodes within this distance of the base plane x = min are clamped, m.
    """

    def __init__(self, robot, mesh: TetMesh | None = None, *, n_rings=None, n_axial=None, clamp_tol_m=1e-9):
        self.robot = robot
        self.mesh = robot_mesh(robot, n_rings, n_axial) if mesh is None else mesh
        X = self.mesh.X_W
        self.clamped = X[:, 0] <= X[:, 0].min() + clamp_tol_m

    def markers(self) -> dict[str, Marker]:
        """The tip marker, then the description's markers (inside, or on stalks).

        Returns
        -------
        dict of str to Marker
            ``{"tip": ..., NAME: ...}``: the description's ``p_tip_marker_W`` embedded
            (barycentric), then ``robot.markers`` in order (:mod:`lab.fem.bodies.markers`).
        """
        return body_markers(self, self.robot)

    def embed(self, points_W, what: str) -> tuple[np.ndarray, np.ndarray]:
        """:func:`~lab.fem.bodies.mesh.barycentric` embedding of ``points_W`` (m), naming the point outside.

        Parameters
        ----------
        points_W : array_like, shape (P, 3) or (3,)
            Points in frame W, m.
        what : str
            What the points are (e.g. ``"cable 'top' via point"``).

        Returns
        -------
        nodes, weights : ndarray, shape (P, 4)
            Each point's tet nodes and barycentric weights.
        """
        return embed_points(self.mesh, points_W, what, "a faceted cylinder, slightly inside the description's radius")
