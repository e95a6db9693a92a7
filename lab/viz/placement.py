"""Chapter 04's placement figure: the target trajectories inside the reachable workspace.

:func:`plot_trajectory_placement` draws the built-in trajectories (frame W, m, drawn in cm)
in two views. Front (y-z): each shape as a closed curve over the region the learned model
can reach in the plane of the trajectories (the reachable radius per direction, found by the
chapter). Side (x-z): the shapes against the training data's tips and the plane x = centre.

The planar shapes (circle, square, rose) all lie in one plane x = const, so in the side view
each is a vertical stroke at the same x: drawn as thin lines, the last one hid the others.
Here they share one dashed stroke at their x: the z range of all of them is cut into short
dashes that the planar shapes take in turn, each within its own z range, so that every colour
shows at its true place; shapes that span x (the helix) are dots beneath.
Colours: matplotlib's ``tab10`` in the order of ``shapes``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_trajectory_placement"]

#: Below this spread along x (m) a shape counts as planar (drawn as a band in the side view).
PLANAR_SPREAD_M = 1e-4
#: The side view's shared dashes: this many per planar shape along the z range of all of them.
DASHES = 15


def plot_trajectory_placement(shapes, centre_W, angles_rad, r_max_m, p_data_W=None, *, figsize=(10, 5.5)):
    """The trajectories over the reachable region at x = ``centre_W[0]``, front (y-z) and
    side (x-z) views, in cm.

    Parameters
    ----------
    shapes : dict
        ``{name: points (N, 3)}`` (m, frame W).
    centre_W : array_like, shape (3,)
        Centre of the reachable region (m).
    angles_rad, r_max_m : array_like, shape (K,)
        Directions in the y-z plane (rad) and the reachable radius in each (m).
    p_data_W : array_like, shape (M, 3), optional
        The training data's tips (m), drawn in the side view.
    figsize : tuple of float, optional
        Figure size (inches).

    Returns
    -------
    tuple
        ``(fig, (ax_front, ax_side))``: the matplotlib Figure and its two axes.
    """
    import matplotlib.pyplot as plt

    centre = np.asarray(centre_W, float)
    angles, r_max = np.asarray(angles_rad, float), np.asarray(r_max_m, float)
    fig, (ax_yz, ax_xz) = plt.subplots(
        1, 2, figsize=figsize, layout="constrained", gridspec_kw={"width_ratios": (1.6, 1)}
    )
    ring, rr = np.append(angles, angles[:1]), np.append(r_max, r_max[:1])
    ax_yz.fill(
        100 * (centre[1] + rr * np.cos(ring)),
        100 * (centre[2] + rr * np.sin(ring)),
        color="0.9",
        label=f"reachable at x = {100 * centre[0]:.1f} cm",
    )
    if p_data_W is not None:
        p_data = np.asarray(p_data_W, float)
        ax_xz.scatter(100 * p_data[:, 0], 100 * p_data[:, 2], s=6, c="0.7", label="training data tips", zorder=1)
    planar = [name for name, p in shapes.items() if np.ptp(np.asarray(p)[:, 0]) < PLANAR_SPREAD_M]
    z_all = np.concatenate([np.asarray(shapes[name])[:, 2] for name in planar]) if planar else np.zeros(1)
    z_span = (z_all.min(), z_all.max())
    for (name, p), c in zip(shapes.items(), plt.cm.tab10.colors):
        p = np.asarray(p, float)
        closed = p if name not in planar else np.vstack([p, p[:1]])
        ax_yz.plot(100 * closed[:, 1], 100 * closed[:, 2], "-", color=c, label=name)
        if name in planar:  # their turn of the shared dashes, over the shapes that span x
            x, z = _dashes(p, planar.index(name), len(planar), z_span)
            ax_xz.plot(100 * x, 100 * z, "-", color=c, lw=3.0, solid_capstyle="butt", label=name, zorder=3)
        else:
            ax_xz.plot(100 * p[:, 0], 100 * p[:, 2], ".", color=c, ms=3, label=name, zorder=2)
    ax_xz.axvline(100 * centre[0], color="0.5", ls="--", lw=0.8, zorder=1.5)
    for ax, (a, b), title in ((ax_yz, ("y", "z"), "front view (y-z)"), (ax_xz, ("x", "z"), "side view (x-z)")):
        ax.set(xlabel=f"{a} [cm]", ylabel=f"{b} [cm]", title=title, aspect="equal")
        ax.grid(alpha=0.3)
    ax_yz.legend(fontsize=8, loc="lower left")
    ax_xz.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.02, 0.5))
    fig.suptitle("the target trajectories and the reachable workspace (through the learned model)")
    return fig, (ax_yz, ax_xz)


def _dashes(p, j: int, n: int, z_span) -> tuple[np.ndarray, np.ndarray]:
    """The side-view dashes of planar shape ``j`` of ``n`` (points ``p`` (N, 3) m): every n-th
    of ``n * DASHES`` equal pieces of ``z_span`` (m), starting with piece j, cut to the shape's
    own z range. Returns x and z (m) with NaN between the dashes."""
    z0, z1 = z_span
    edges = np.linspace(z0, z1, n * DASHES + 1)
    lo, hi = p[:, 2].min(), p[:, 2].max()
    x, z = [], []
    for a, b in zip(edges[j::n], edges[j + 1 :: n]):
        a, b = max(a, lo), min(b, hi)
        if b > a:
            x += [p[0, 0], p[0, 0], np.nan]
            z += [a, b, np.nan]
    return np.array(x), np.array(z)
