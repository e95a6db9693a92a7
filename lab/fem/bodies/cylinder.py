"""The structured cylinder of a robot description, clamped at its base, with its tip marker.

The body every description has today: ``lab.fem.bodies.mesh.robot_mesh`` (or a given
mesh), the nodes of the base face x = min clamped, and the description's tip marker
``p_tip_marker_W`` as the marker ``"tip"``.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.fem.bodies.base import Body, Marker, register_body
from lab.fem.bodies.mesh import TetMesh, barycentric, robot_mesh


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
        """The tip marker.

        Returns
        -------
        dict of str to Marker
            ``{"tip": ...}``, the description's ``p_tip_marker_W`` embedded.
        """
        nodes, weights = (a[0] for a in self.embed(self.robot.p_tip_marker_W, "the tip marker"))
        return {"tip": Marker(nodes, weights)}

    def embed(self, points_W, what: str) -> tuple[np.ndarray, np.ndarray]:
        """:func:`barycentric` embedding of ``points_W`` (m), naming the point outside.

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
        mesh = self.mesh
        points_W = np.atleast_2d(points_W)
        try:
            return barycentric(mesh, points_W)
        except InputError:
            for i, p in enumerate(points_W):
                try:
                    barycentric(mesh, p)
                except InputError:
                    which = f"{what} {i} " if len(points_W) > 1 else f"{what} "
                    raise InputError(
                        f"{which}{np.round(p, 6).tolist()} m lies outside the mesh of the body (a faceted "
                        "cylinder, slightly inside the description's radius): move it inwards in the description"
                    ) from None
            raise
