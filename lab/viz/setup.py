"""Figure 1 of the paper, drawn from the robot description: the set-up.

The paper's Figure 1 is a photograph of the rig: the foam arm clamped horizontally to a base
plate, its cables running through eyelets to spools on Dynamixel motors behind the plate, a
motion-capture marker on the tip and markers on the base that define frame W. :func:`plot_setup`
draws the same from what ``lab`` knows, so it is right for any robot description and any
hardware configuration: the body (rest shape, frame W: x along the body, z up, gravity along
-z); each cable's route from its anchor on the base face through its via points (eyelets) to
where it is tied off, coloured per cable; the spools behind the base plate (radius from
``[actuation].spool_radius_m``), one per motor, on the line from the cable's anchor straight
back, stepped further back where two would be drawn on top of each other (a disc in the side
view, a drum seen from above in the top view); the tip marker, and the base markers of a hardware configuration
(``[[mocap.base_markers]]``) when one is given.

Side view (x-z), top view (x-y) and the base face seen from the tip (y-z), in cm; the cables'
names in the section sit centred above or below their eyelets, inside its frame.
"""

from __future__ import annotations

import numpy as np

from lab.viz.arm import FOAM_RGB, TIP_RGB
from lab.viz.style import CABLE_COLORS

__all__ = ["SPOOL_SETBACK_M", "plot_setup", "setup_geometry"]

#: How far behind the base face (m, along -x) the spools are drawn: a schematic
#: distance (the description does not place the motors), the paper's rig is similar.
SPOOL_SETBACK_M = 0.04
PLATE_THICKNESS_M = 0.01
MARKER_RGB = (0.1, 0.1, 0.1)


def setup_geometry(robot, base_markers_W_m=None) -> dict:
    """What Figure 1 draws, in frame W (m): ``routes`` (per cable, (K+1, 3) anchor then via
    points), ``spools`` (n_cables, 3) spool centres, ``spool_radius_m``, ``drum_width_m`` (a spool's
    width along its axis y, as drawn in the top view), ``tip`` (3,),
    ``base_markers`` (B, 3) (empty if none given), ``length_m`` and ``radius_m``."""
    routes = [np.vstack([c.anchor_m, c.via_points_m]) for c in robot.cables]
    r = robot.spool_radius_m
    spools: list = []
    for c in robot.cables:  # straight back from the anchor, one more step back while it clashes
        back = SPOOL_SETBACK_M + PLATE_THICKNESS_M
        while any(_clash(c.anchor_m + [-back, 0.0, 0.0], other, r) for other in spools):
            back += 2.6 * r
        spools.append(c.anchor_m + [-back, 0.0, 0.0])
    spools = np.array(spools)
    markers = np.zeros((0, 3)) if base_markers_W_m is None else np.asarray(base_markers_W_m, float).reshape(-1, 3)
    return {
        "routes": routes,
        "spools": spools,
        "spool_radius_m": r,
        "drum_width_m": _drum_width(spools, r),
        "tip": np.asarray(robot.p_tip_marker_W, float),
        "base_markers": markers,
        "length_m": robot.length_m,
        "radius_m": robot.radius_m,
    }


def _clash(a, b, r: float) -> bool:
    """Whether spools (radius ``r``, axis along y) centred at ``a`` and ``b`` (3,) m would be
    drawn on top of each other: overlapping discs in the side view, or discs that coincide
    there (same x and z) with too little room between them in y for two drums in the top view."""
    dx, dy, dz = np.abs(np.asarray(a) - np.asarray(b))
    if dx >= 2.05 * r:
        return False
    return bool(np.hypot(dx, dz) < 2.05 * r and (np.hypot(dx, dz) > 1e-9 or dy < 0.4 * r))


def _drum_width(spools: np.ndarray, r: float) -> float:
    """The width (m, along y) a spool is drawn with in the top view: 1.2 r, or less where two
    spools side by side in y would touch (60 % of their gap)."""
    gaps = [
        abs(a[1] - b[1])
        for i, a in enumerate(spools)
        for b in spools[i + 1 :]
        if abs(a[0] - b[0]) < 2.05 * r and abs(a[1] - b[1]) > 1e-9
    ]
    return float(min([1.2 * r, *(0.6 * g for g in gaps)]))


def _body_outline(ax, geo, dims, s):
    """The body: a rectangle (side/top views) or the section circle (base face view)."""
    from matplotlib.patches import Circle, Rectangle

    L, r = s * geo["length_m"], s * geo["radius_m"]
    if dims[0] == 0:  # along the body
        ax.add_patch(Rectangle((0, -r), L, 2 * r, facecolor=(*FOAM_RGB, 0.35), edgecolor=FOAM_RGB, lw=1.5))
        t = s * PLATE_THICKNESS_M
        ax.add_patch(Rectangle((-t, -2.2 * r), t, 4.4 * r, facecolor="0.75", edgecolor="0.4", lw=1))
    else:
        ax.add_patch(Circle((0, 0), r, facecolor=(*FOAM_RGB, 0.35), edgecolor=FOAM_RGB, lw=1.5))


def _spools(ax, geo, dims, s, colors):
    """The spools behind the base plate, each with its motor behind it (dark): a disc in the
    side view (x-z, the spool's axis is y), a drum of width ``drum_width_m`` in the top view."""
    from matplotlib.patches import Circle, Rectangle

    rs, half = s * geo["spool_radius_m"], 0.5 * s * geo["drum_width_m"]
    for k, (c, a) in enumerate(zip(geo["spools"], geo["routes"])):
        p = s * c[list(dims)]
        if dims[1] == 2:  # side view: the cable leaves the disc towards its anchor
            ax.add_patch(Circle(p, rs, facecolor="white", edgecolor=colors[k], lw=1.5, gid="spool"))
            ax.add_patch(Rectangle((p[0] - 1.6 * rs, p[1] - 0.6 * rs), 0.6 * rs, 1.2 * rs, color="0.3", gid="motor"))
        else:  # top view: the drum seen from above, its motor behind it
            ax.add_patch(
                Rectangle((p[0] - rs, p[1] - half), 2 * rs, 2 * half, facecolor="white", edgecolor=colors[k],
                          lw=1.5, gid="spool")
            )  # fmt: skip
            ax.add_patch(Rectangle((p[0] - 1.6 * rs, p[1] - half), 0.6 * rs, 2 * half, color="0.3", gid="motor"))
        ax.plot([p[0], s * a[0, dims[0]]], [p[1], s * a[0, dims[1]]], color=colors[k], lw=1.2, ls=":")


def _draw(ax, geo, dims, s, names, title, label_cables):
    colors = [CABLE_COLORS[k % len(CABLE_COLORS)] for k in range(len(geo["routes"]))]
    _body_outline(ax, geo, dims, s)
    if dims[0] == 0:
        _spools(ax, geo, dims, s, colors)
    for k, pts in enumerate(geo["routes"]):
        p = s * pts[:, list(dims)]
        label = names[k] if label_cables else None
        if dims[0] == 0:
            ax.plot(*p.T, "-", color=colors[k], lw=1.5, label=label)
            ax.plot(*p[1:].T, "o", color=colors[k], ms=4, mfc="white")  # eyelets
            ax.plot(*p[-1], "s", color=colors[k], ms=5)  # tied off
        else:  # the section: each cable is one point (its eyelets line up along x)
            ax.plot(*p[1:].T, "o", color=colors[k], ms=7, mfc="white", label=label)
    if dims[0] != 0:  # one label per place, listing every cable there, centred above or below
        places: dict = {}  # it (away from the middle), so that it stays inside the section
        for k, pts in enumerate(geo["routes"]):
            places.setdefault(tuple(np.round(s * pts[-1, list(dims)], 3)), []).append(k)
        for xy, ks in places.items():
            up = xy[1] >= 0
            for j, k in enumerate(ks[::-1] if up else ks):  # first cable on top
                ax.annotate(
                    names[k], xy, textcoords="offset points", xytext=(0, (7 + 10 * j) * (1 if up else -1)),
                    ha="center", va="bottom" if up else "top", color=colors[k], fontsize=8,
                    bbox={"boxstyle": "square,pad=0.05", "fc": "white", "ec": "none", "alpha": 0.7},
                )  # fmt: skip
    tip = s * geo["tip"][list(dims)]
    ax.plot(*tip, "o", color=TIP_RGB, ms=8, label="tip marker" if label_cables else None, zorder=5)
    if len(geo["base_markers"]):
        m = s * geo["base_markers"][:, list(dims)]
        ax.plot(*m.T, "D", color=MARKER_RGB, ms=6, label="base markers (frame W)" if label_cables else None)
    ax.set_aspect("equal")
    ax.set_xlabel(f"{'xyz'[dims[0]]} [cm]")
    ax.set_ylabel(f"{'xyz'[dims[1]]} [cm]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)


def plot_setup(robot, base_markers_W_m=None, *, figsize=(12, 6.2)):
    """Figure 1 equivalent for ``robot``: side (x-z), top (x-y) and base-face (y-z) views of
    the set-up in cm, with the spools, cable routes through their eyelets, the tip marker and,
    if given, the base markers.

    Parameters
    ----------
    robot : RobotDescription
        The robot (:class:`lab.description.RobotDescription`).
    base_markers_W_m : array_like, shape (B, 3), optional
        Base markers (m, frame W; e.g. ``HardwareConfig.natnet.base_positions_W_m``).
    figsize : tuple of float, optional
        Figure size (inches).

    Returns
    -------
    tuple
        ``(fig, (ax_side, ax_top, ax_face))``: the matplotlib Figure and its three axes.
    """
    import matplotlib.pyplot as plt

    geo = setup_geometry(robot, base_markers_W_m)
    s = 100.0
    names = [c.name for c in robot.cables]
    fig = plt.figure(figsize=figsize, layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=(2.6, 1))
    ax_side, ax_top, ax_face = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[:, 1])
    _draw(ax_side, geo, (0, 2), s, names, "side view (x-z): gravity along -z", True)
    _draw(ax_top, geo, (0, 1), s, names, "top view (x-y)", False)
    _draw(ax_face, geo, (1, 2), s, names, "cross-section: eyelets (y-z)", False)
    # the same x range for both long views, with room for the spools behind the plate
    x_lo = s * (geo["spools"][:, 0].min() - 2.0 * geo["spool_radius_m"])
    x_hi = s * (geo["length_m"] + 0.02)
    for ax in (ax_side, ax_top):
        ax.set_xlim(x_lo, x_hi)
    ax_side.annotate(
        "",
        xy=(s * 0.6 * geo["length_m"], -s * 2.0 * geo["radius_m"]),
        xytext=(s * 0.6 * geo["length_m"], -s * 1.2 * geo["radius_m"]),
        arrowprops={"arrowstyle": "->", "color": "0.3"},
    )
    ax_side.text(s * 0.61 * geo["length_m"], -s * 1.7 * geo["radius_m"], "g", color="0.3")
    ax_side.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    fig.suptitle(
        f"{robot.name}: {len(names)} cables, spools r = {100 * robot.spool_radius_m:g} cm behind the base plate "
        "(drawn from the robot description)",
        fontsize=11,
    )
    return fig, (ax_side, ax_top, ax_face)
