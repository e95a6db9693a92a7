"""A tapered body: a solid of revolution along +x whose radius is piecewise linear in x.

:func:`tapered_mesh` is the structured cylinder mesher of :mod:`.mesh` with each layer's
disk scaled to the profile's radius there; a two-station profile of constant radius gives
:func:`~lab.fem.bodies.mesh.cylinder_mesh` bit for bit. :class:`TaperedBody` clamps its
base and embeds its markers (:mod:`lab.fem.bodies.markers`) like the cylinder.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.fem.bodies.base import Body, Marker, register_body
from lab.fem.bodies.markers import body_markers, embed_points
from lab.fem.bodies.mesh import TetMesh, check_mesh_size, layered_mesh

__all__ = ["TaperedBody", "tapered_mesh"]


def tapered_mesh(profile_m, n_rings: int, n_axial: int) -> TetMesh:
    """Structured tet mesh of a tapered solid of revolution along +x.

    Parameters
    ----------
    profile_m : array_like, shape (S, 2)
        Stations [x, r], m: x0 = 0, x increasing (the last x is the length), r > 0; the
        radius is linear between stations.
    n_rings : int
        Rings across each disk (>= 1).
    n_axial : int
        Layers along the length (>= 1), at ``np.linspace(0, L, n_axial + 1)`` like the cylinder's.

    Returns
    -------
    TetMesh
        The oriented mesh in frame W, ``(1 + 3 n_rings (n_rings + 1)) (n_axial + 1)`` nodes.
    """
    profile = np.asarray(profile_m, float)
    if profile.ndim != 2 or profile.shape[1] != 2 or len(profile) < 2:
        raise InputError(f"a profile is a list of at least two [x_m, r_m] stations, got shape {profile.shape}")
    if profile[0, 0] != 0 or np.any(np.diff(profile[:, 0]) <= 0) or np.any(profile[:, 1] <= 0):
        raise InputError(f"a profile starts at x = 0, increases in x and has positive radii, got {profile.tolist()}")
    check_mesh_size(n_rings, n_axial)
    xs = np.linspace(0.0, profile[-1, 0], n_axial + 1)
    return layered_mesh(xs, np.interp(xs, profile[:, 0], profile[:, 1]), n_rings)


@register_body("tapered")
class TaperedBody(Body):
    """The description's tapered body (``body_shape.profile_m``), base face clamped.

    Parameters
    ----------
    robot : RobotDescription
        Its ``body_shape.profile_m`` (S, 2) m, mesh resolution, tip marker and markers.
    mesh : TetMesh, optional
        A mesh instead of the structured one.
    n_rings, n_axial : int, optional
        Override the description's resolution (without ``mesh``).
    clamp_tol_m : float
        Nodes within this distance of the base plane x = min are clamped, m.
    """

    def __init__(self, robot, mesh: TetMesh | None = None, *, n_rings=None, n_axial=None, clamp_tol_m=1e-9):
        self.robot = robot
        if mesh is None:
            n_rings = robot.n_rings if n_rings is None else n_rings
            n_axial = robot.n_axial if n_axial is None else n_axial
            mesh = tapered_mesh(robot.body_shape.profile_m, n_rings, n_axial)
        self.mesh = mesh
        X = self.mesh.X_W
        self.clamped = X[:, 0] <= X[:, 0].min() + clamp_tol_m

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
            Each point's tet nodes and barycentric weights.
        """
        return embed_points(self.mesh, points_W, what, "a faceted solid of revolution, slightly inside the profile")
