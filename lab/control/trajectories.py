"""Target trajectories for the tip: the paper's circle, square and rose, a 3-D helix, or a CSV.

All targets are tip-marker positions ``p_tip_W`` (N, 3) in metres, frame W (base centre
at the origin, arm along +x, gravity along -z). The three-cable shapes (:data:`BUILTIN`:
circle, square, rose, helix; Fig. 3-4) are drawn about :data:`CENTRE_W` in the plane
facing the arm, 6 to 10 cm across (Section V-A); the six-cable paths (:data:`SIX_CABLE`,
Section V-B) are centred on the two-stage arm's axis. A CSV trajectory has the header
``x,y,z`` and one point per row, in metres, frame W. Why each shape sits where it does
(the reachable workspace): docs/design/ik.md (trajectories).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_write_text

CENTRE_W = np.array([0.184, 0.0, -0.006])
BUILTIN = ("circle", "square", "rose", "helix")
#: Paths for the six-cable arm (module docstring); also accepted by :func:`builtin`.
SIX_CABLE = ("six-circle", "six-ring", "six-saddle", "six-spiral")
SIX_CABLE_AXIS_W = np.array([0.0, 0.0, 0.0])  # (y, z) of the six-cable workspace's axis
DEFAULT_POINTS = {
    "circle": 100,
    "square": 100,
    "rose": 200,
    "helix": 150,
    "six-circle": 100,
    "six-ring": 120,
    "six-saddle": 160,
    "six-spiral": 200,
}
#: Coordinates larger than this (m) in a CSV are taken as a units mistake (mm or cm).
MAX_ABS_COORD_M = 2.0


class TrajectoryError(InputError):
    """An unknown trajectory name, or a trajectory CSV that is missing or malformed."""


def _in_plane(y_m: np.ndarray, z_m: np.ndarray, centre_W) -> np.ndarray:
    c = np.asarray(centre_W, dtype=float)
    return np.column_stack([np.full_like(y_m, c[0]), c[1] + y_m, c[2] + z_m])


def _check_n(n_points: int, minimum: int = 2) -> int:
    if int(n_points) != n_points or n_points < minimum:
        raise TrajectoryError(f"n_points must be an integer >= {minimum}, got {n_points!r}")
    return int(n_points)


def circle(n_points: int = 100, radius_m: float = 0.035, centre_W=CENTRE_W) -> np.ndarray:
    """Equally spaced points on a circle in the plane x = centre x.

    Parameters
    ----------
    n_points : int
        N, >= 3.
    radius_m : float
        Radius (m).
    centre_W : array_like
        Centre (3,), m, frame W.

    Returns
    -------
    numpy.ndarray
        Points (N, 3), m, frame W.
    """
    t = 2 * np.pi * np.arange(_check_n(n_points, 3)) / n_points
    return _in_plane(radius_m * np.cos(t), radius_m * np.sin(t), centre_W)


def square(n_points: int = 100, side_m: float = 0.06, centre_W=CENTRE_W) -> np.ndarray:
    """Points equally spaced along the perimeter of an axis-aligned square in the plane x = centre x.

    Starts at the (+y, -z) corner, counter-clockwise; corners are hit exactly when
    ``n_points`` is a multiple of 4.

    Parameters
    ----------
    n_points : int
        N, >= 4.
    side_m : float
        Side length (m).
    centre_W : array_like
        Centre (3,), m, frame W.

    Returns
    -------
    numpy.ndarray
        Points (N, 3), m, frame W.
    """
    s = 4.0 * np.arange(_check_n(n_points, 4)) / n_points  # perimeter parameter in [0, 4)
    side, f = np.floor(s).astype(int), s - np.floor(s)
    h = 0.5 * side_m
    corners = np.array([[h, -h], [h, h], [-h, h], [-h, -h], [h, -h]])
    yz = corners[side] + f[:, None] * (corners[side + 1] - corners[side])
    return _in_plane(yz[:, 0], yz[:, 1], centre_W)


def rose(n_points: int = 200, radius_m: float = 0.035, k: int = 2, centre_W=CENTRE_W) -> np.ndarray:
    """Rhodonea ``r = radius cos(k t)``: 2k petals for even k, k for odd k, each traced once.

    Parameters
    ----------
    n_points : int
        N, >= 4, equally spaced in t.
    radius_m : float
        Petal length (m).
    k : int
        Petal parameter, >= 1.
    centre_W : array_like
        Centre (3,), m, frame W.

    Returns
    -------
    numpy.ndarray
        Points (N, 3), m, frame W.
    """
    if int(k) != k or k < 1:
        raise TrajectoryError(f"rose k must be a positive integer, got {k!r}")
    period = 2 * np.pi if k % 2 == 0 else np.pi
    t = period * np.arange(_check_n(n_points, 4)) / n_points
    r = radius_m * np.cos(k * t)
    return _in_plane(r * np.cos(t), r * np.sin(t), centre_W)


def helix(
    n_points: int = 150,
    radius_m: float = 0.03,
    turns: float = 3.0,
    x_start_m: float = 0.189,
    x_end_m: float = 0.180,
    centre_W=CENTRE_W,
) -> np.ndarray:
    """Helix about the line through ``centre_W`` along x.

    Parameters
    ----------
    n_points : int
        N, >= 2 (both ends included).
    radius_m : float
        Radius (m).
    turns : float
        Number of turns.
    x_start_m, x_end_m : float
        x (m, frame W) at the start and the end; linear in between.
    centre_W : array_like
        A point (3,) of the axis, m, frame W.

    Returns
    -------
    numpy.ndarray
        Points (N, 3), m, frame W.
    """
    s = np.linspace(0.0, 1.0, _check_n(n_points))
    t = 2 * np.pi * turns * s
    p = _in_plane(radius_m * np.cos(t), radius_m * np.sin(t), centre_W)
    p[:, 0] = x_start_m + s * (x_end_m - x_start_m)
    return p


def saddle(
    n_points: int = 160,
    radius_m: float = 0.06,
    x_mid_m: float = 0.17,
    dx_m: float = 0.004,
    waves: int = 2,
    centre_W=SIX_CABLE_AXIS_W,
) -> np.ndarray:
    """A circle about the x axis through ``centre_W`` whose x goes ``x_mid_m + dx_m cos(waves t)``.

    Parameters
    ----------
    n_points : int
        N, >= 4, equally spaced in t.
    radius_m : float
        Radius (m).
    x_mid_m, dx_m : float
        Mean x and amplitude of x (m, frame W).
    waves : int
        Waves of x per turn.
    centre_W : array_like
        A point (3,) of the axis, m, frame W.

    Returns
    -------
    numpy.ndarray
        A closed 3-D curve (N, 3), m, frame W.
    """
    t = 2 * np.pi * np.arange(_check_n(n_points, 4)) / n_points
    p = _in_plane(radius_m * np.cos(t), radius_m * np.sin(t), centre_W)
    p[:, 0] = x_mid_m + dx_m * np.cos(waves * t)
    return p


def conical_spiral(
    n_points: int = 200,
    r_start_m: float = 0.01,
    r_end_m: float = 0.08,
    turns: float = 3.0,
    x_start_m: float = 0.188,
    x_end_m: float = 0.160,
    centre_W=SIX_CABLE_AXIS_W,
) -> np.ndarray:
    """Spiral (N, 3) m about the x axis through ``centre_W``: radius and x both change
    linearly from start to end (both ends included) over ``turns`` turns."""
    s = np.linspace(0.0, 1.0, _check_n(n_points))
    t, r = 2 * np.pi * turns * s, r_start_m + s * (r_end_m - r_start_m)
    p = _in_plane(r * np.cos(t), r * np.sin(t), centre_W)
    p[:, 0] = x_start_m + s * (x_end_m - x_start_m)
    return p


def _six(x_m: float, radius_m: float):
    return lambda n: circle(n, radius_m, (x_m, *SIX_CABLE_AXIS_W[1:]))


def builtin(name: str, n_points: int | None = None) -> np.ndarray:
    """A built-in trajectory by name, with default sizes and placement.

    Parameters
    ----------
    name : str
        One of :data:`BUILTIN` or :data:`SIX_CABLE`.
    n_points : int, optional
        N; default :data:`DEFAULT_POINTS` of the name.

    Returns
    -------
    numpy.ndarray
        Targets (N, 3), m, frame W.
    """
    makers = {
        "circle": circle,
        "square": square,
        "rose": rose,
        "helix": helix,
        "six-circle": _six(0.18, 0.04),
        "six-ring": _six(0.165, 0.07),
        "six-saddle": saddle,
        "six-spiral": conical_spiral,
    }
    if name not in makers:
        raise TrajectoryError(
            f"unknown trajectory {name!r}: built-in are {', '.join(BUILTIN + SIX_CABLE)}, "
            f"or give the path of a CSV file with header x,y,z (metres)"
        )
    return makers[name](DEFAULT_POINTS[name] if n_points is None else n_points)


def load_trajectory(name_or_csv: str | Path, n_points: int | None = None) -> np.ndarray:
    """Targets from a built-in name or a CSV file.

    Parameters
    ----------
    name_or_csv : str or pathlib.Path
        A built-in name (:func:`builtin`), or a CSV path (:func:`read_trajectory_csv`).
    n_points : int, optional
        N for a built-in name; must be None for a CSV.

    Returns
    -------
    numpy.ndarray
        Targets (N, 3), m, frame W.
    """
    text = str(name_or_csv)
    if text in BUILTIN + SIX_CABLE:
        return builtin(text, n_points)
    if text.lower().endswith(".csv") or Path(text).exists():
        if n_points is not None:
            raise TrajectoryError("n_points applies to built-in trajectories only, not to a CSV file")
        return read_trajectory_csv(text)
    return builtin(text, n_points)  # raises, listing the names


def read_trajectory_csv(path: str | Path) -> np.ndarray:
    """Read a CSV with header ``x,y,z`` (metres, frame W) -> (N, 3); TrajectoryError naming
    the file, line and problem for anything else. UTF-8 text, with or without the byte-order
    mark a spreadsheet writes first, lines ending in LF or CRLF."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")  # newlines: LF, CRLF and CR all end a line
    except FileNotFoundError:
        raise TrajectoryError(f"trajectory file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as err:
        raise TrajectoryError(f"{path}: cannot read trajectory file ({err})") from None
    rows = [r for r in csv.reader(io.StringIO(text)) if r and any(c.strip() for c in r)]
    if not rows:
        raise TrajectoryError(f"{path}: empty file; expected a header x,y,z and one point per row")
    header = [c.strip().lower() for c in rows[0]]
    if header != ["x", "y", "z"]:
        raise TrajectoryError(f"{path}: header must be x,y,z (metres), got {','.join(rows[0])}")
    if len(rows) < 2:
        raise TrajectoryError(f"{path}: no points after the header")
    pts = np.empty((len(rows) - 1, 3))
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != 3:
            raise TrajectoryError(f"{path}: line {i} has {len(row)} fields, expected 3 (x,y,z)")
        try:
            pts[i - 2] = [float(c) for c in row]
        except ValueError:
            raise TrajectoryError(f"{path}: line {i} has a non-numeric value: {','.join(row)}") from None
        if not np.all(np.isfinite(pts[i - 2])):
            raise TrajectoryError(f"{path}: line {i} has a NaN or infinite value: {','.join(row)}")
    if np.max(np.abs(pts)) > MAX_ABS_COORD_M:
        raise TrajectoryError(
            f"{path}: coordinates up to {np.max(np.abs(pts)):g} -- the file must be in "
            f"metres (|x|, |y|, |z| <= {MAX_ABS_COORD_M} m); millimetres or centimetres?"
        )
    return pts


def write_trajectory_csv(path: str | Path, points_W) -> None:
    """Write targets as a CSV with header x,y,z (atomic).

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write.
    points_W : array_like
        Finite targets (N, 3), m, frame W.
    """
    pts = np.asarray(points_W, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
        raise TrajectoryError(f"points must be a finite (N, 3) array, got shape {pts.shape}")
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["x", "y", "z"])
    writer.writerows([[repr(float(v)) for v in p] for p in pts])
    atomic_write_text(path, buf.getvalue())
