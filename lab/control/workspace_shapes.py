"""The paper's circle, square and rose scaled into another robot's reachable workspace.

The paper draws its shapes 6 to 10 cm across about :data:`~lab.control.trajectories.CENTRE_W`,
in the plane facing its foam arm: the three-cable arm's workspace. Another robot reaches
another region -- a pneumatic arm of the same size bends its tip a centimetre or two, a
six-cable arm twice as far. :func:`fitted_shape` keeps each shape's form and its proportions
to the others (circle radius 35, square side 60, rose petals 35, in the same units), and
places and scales it for a robot from tip positions it is known to reach (a dataset's): the
shapes lie in the plane x = the median x of those positions, centred on the middle of their
(y, z) spread, and scaled to ``fill`` of the largest size whose every point lies inside the
convex hull of the (y, z) of the reachable positions near that plane. Shapes that fit so
are reachable in the tip's plane up to the hull's approximation of the true cross-section,
which ``fill`` < 1 leaves room for.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from lab.control.trajectories import BUILTIN, CENTRE_W, TrajectoryError, builtin

__all__ = ["fitted_shape", "workspace_plane"]

#: The reachable positions within this share of their x range of the plane count as in it.
PLANE_BAND = 0.25


def workspace_plane(reachable_W) -> tuple[np.ndarray, np.ndarray]:
    """The plane and cross-section a robot's shapes are fitted into.

    Parameters
    ----------
    reachable_W : array_like, shape (N, 3)
        Tip positions the robot reaches, m, frame W (N >= 8).

    Returns
    -------
    centre_W : ndarray, shape (3,)
        The shapes' centre: the median x, the middle of the (y, z) range near that plane, m.
    section_yz : ndarray, shape (M, 2)
        The (y, z) of the reachable positions near the plane, m.
    """
    P = np.asarray(reachable_W, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or len(P) < 8 or not np.all(np.isfinite(P)):
        raise TrajectoryError(f"reachable tip positions must be (N >= 8, 3) finite metres, got shape {P.shape}")
    x_c = float(np.median(P[:, 0]))
    span = float(np.ptp(P[:, 0]))
    near = P[np.abs(P[:, 0] - x_c) <= PLANE_BAND * span + 1e-12]
    near = near if len(near) >= 8 else P
    yz = near[:, 1:]
    centre = np.array([x_c, *(0.5 * (yz.min(axis=0) + yz.max(axis=0)))])
    return centre, yz


def fitted_shape(name: str, reachable_W, n_points: int | None = None, fill: float = 0.6) -> np.ndarray:
    """A paper shape placed and scaled into the workspace that ``reachable_W`` samples.

    Parameters
    ----------
    name : str
        ``"circle"``, ``"square"`` or ``"rose"``.
    reachable_W : array_like, shape (N, 3)
        Tip positions the robot reaches (e.g. a dataset's ``x, y, z``), m, frame W.
    n_points : int, optional
        Points on the shape; default the paper's (:data:`~lab.control.trajectories.DEFAULT_POINTS`).
    fill : float
        The share, in (0, 1], of the largest size that fits inside the cross-section's hull.

    Returns
    -------
    ndarray, shape (n_points, 3)
        Targets, m, frame W.
    """
    if name not in BUILTIN[:3]:
        raise TrajectoryError(f"fitted shapes are circle, square and rose, got {name!r}")
    if not 0 < fill <= 1:
        raise TrajectoryError(f"fill must be in (0, 1], got {fill!r}")
    centre, yz = workspace_plane(reachable_W)
    try:
        hull = ConvexHull(yz)
    except QhullError:
        raise TrajectoryError("the reachable positions span no area in (y, z): no shape fits") from None
    unit = (builtin(name, n_points) - CENTRE_W)[:, 1:]  # the paper's size, about the origin
    A, b = hull.equations[:, :2], hull.equations[:, 2]
    if np.any(A @ centre[1:] + b > 0):
        raise TrajectoryError("the middle of the reachable positions lies outside their hull: no shape fits")
    # Largest k with A (c + k p) + b <= 0 for every point p: k <= -(A c + b) / (A p) where A p > 0.
    Ap = unit @ A.T
    slack = -(A @ centre[1:] + b)
    k = float(np.min(np.where(Ap > 0, slack[None, :] / np.where(Ap > 0, Ap, 1.0), np.inf)))
    pts = centre[None, 1:] + fill * k * unit
    return np.column_stack([np.full(len(pts), centre[0]), pts])
