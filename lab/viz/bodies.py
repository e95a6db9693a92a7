"""Any body drawn: its mesh, its clamped nodes, every tendon's route and every named marker.

:func:`plot_arm <lab.viz.arm.plot_arm>` draws the cylinder arm with its angle-controlled
cables; a tapered tentacle pulled by tension, or a finger meshed from a CAD file, has
tendons of other actuators and markers on stalks. :func:`plot_body` draws any
:class:`~lab.fem.model.ArmFEM` at a state: the surface of its tet mesh, the routes of every
actuator that has routes (angle cables and tension tendons alike), the clamped nodes, and
each observed marker (the tip first) with its name. Markers on stalks are joined to the
body point their frame follows by a thin line. :func:`plot_body_views` puts a side and a
top view (or any two projections) side by side.
"""

from __future__ import annotations

import numpy as np

from lab.viz.arm import FOAM_RGB, TIP_RGB, UNITS

__all__ = ["MARKER_COLORS", "TENDON_COLORS", "plot_body", "plot_body_views"]

#: Colours of the markers after the tip (which is :data:`~lab.viz.arm.TIP_RGB`).
MARKER_COLORS = ("#1f77b4", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf")
#: Colours of the tendons, in the order of the actuators' routes.
TENDON_COLORS = ("#d62728", "#ff7f0e", "#7f7f7f", "#bcbd22")


def _routes(fem) -> list:
    """(name, route) of every actuator's routes, in the actuators' order (angle cables and
    tension tendons); the name is the one in the actuator's input name, ``u_motor[NAME]``."""
    out = []
    for act in fem.actuators:
        for route, input_name in zip(getattr(act, "routes", []), act.input_names):
            out.append((input_name.split("[", 1)[-1].rstrip("]"), route))
    return out


def plot_body(ax, fem, q=None, *, dims=(0, 2), unit: str = "cm", alpha: float = 0.25, labels: bool = True):
    """Draw ``fem``'s body at ``q`` projected on two world axes.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        A 2-D axes.
    fem : ArmFEM
        The model (any body, any actuators).
    q : array_like, shape (n_free,), optional
        Free coordinates, m; None is the rest shape.
    dims : tuple of int
        The two world axes drawn (0 = x, 1 = y, 2 = z).
    unit : str
        "m", "cm" or "mm".
    alpha : float
        The surface's opacity.
    labels : bool
        Name each marker beside it.

    Returns
    -------
    numpy.ndarray, shape (K, 3)
        The markers drawn (tip first), m, frame W.
    """
    from matplotlib.collections import PolyCollection

    x = fem.X_W.copy() if q is None else fem.to_nodes(np.asarray(q, float))
    s, d = UNITS[unit], list(dims)
    before = (ax.get_xlim(), ax.get_ylim()) if ax.has_data() else None  # another body drawn already: keep it in view
    tris = s * x[fem.mesh.surface_triangles()][:, :, d]
    ax.add_collection(
        PolyCollection(tris, facecolor=(*FOAM_RGB, alpha), edgecolor=(*FOAM_RGB, min(1.0, 2 * alpha)), linewidth=0.2)
    )
    clamped = s * x[np.asarray(fem.body.clamped, bool)][:, d]
    ax.plot(*clamped.T, "s", color="k", markersize=2, label="clamped nodes")
    for k, (name, route) in enumerate(_routes(fem)):
        pts = s * route.points(x)[:, d]
        ax.plot(*pts.T, "-", color=TENDON_COLORS[k % len(TENDON_COLORS)], lw=1.6, label=f"tendon {name}")
    y = fem.observe(x)
    for k, (name, p) in enumerate(zip(fem.marker_names, y)):
        marker = fem.markers[name]
        colour = TIP_RGB if k == 0 else MARKER_COLORS[(k - 1) % len(MARKER_COLORS)]
        if len(marker.nodes) > 4:  # on a stalk: join it to the body nodes its frame follows
            base = s * x[marker.nodes].mean(axis=0)[d]
            ax.plot([base[0], s * p[d[0]]], [base[1], s * p[d[1]]], "-", color=colour, lw=0.8)
        ax.plot(s * p[d[0]], s * p[d[1]], "o", color=colour, markersize=6, markeredgecolor="k", markeredgewidth=0.5)
        if labels:
            ax.annotate(name, (s * p[d[0]], s * p[d[1]]), xytext=(4, 4), textcoords="offset points", fontsize=8)
    pts = np.vstack([x, y])[:, d] * s
    lo, hi = pts.min(0), pts.max(0)
    pad = 0.08 * (hi - lo).max()
    lo, hi = lo - pad, hi + pad
    if before is not None:
        lo = np.minimum(lo, [before[0][0], before[1][0]])
        hi = np.maximum(hi, [before[0][1], before[1][1]])
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel(f"{'xyz'[d[0]]} [{unit}]")
    ax.set_ylabel(f"{'xyz'[d[1]]} [{unit}]")
    return y


def plot_body_views(fem, q=None, *, views=((0, 2), (0, 1)), unit: str = "cm", title: str = "", figsize=(11, 3)):
    """A figure of ``fem``'s body at ``q`` in several projections (:func:`plot_body`).

    Parameters
    ----------
    fem : ArmFEM
        The model.
    q : array_like, shape (n_free,), optional
        Free coordinates, m; None is the rest shape.
    views : sequence of tuple of int
        The world axes of each panel (default x-z, then x-y).
    unit : str
        "m", "cm" or "mm".
    title : str
        The figure's title.
    figsize : tuple of float
        Inches.

    Returns
    -------
    tuple
        ``(fig, axes)``: the matplotlib Figure and its axes, one per view.
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(views), figsize=figsize, layout="constrained", squeeze=False)
    for ax, dims in zip(axes[0], views):
        plot_body(ax, fem, q, dims=dims, unit=unit)
        ax.set_title(f"{'xyz'[dims[0]]}-{'xyz'[dims[1]]} view", fontsize=10)
    axes[0, 0].legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title, fontsize=11)
    return fig, list(axes[0])
