"""Drawing the arm: its deformed foam surface, the cables and the tip marker.

:func:`arm_geometry` is the one place that turns a state ``q`` into drawable geometry
(frame W, metres). Two back ends draw it:

* meshcat (interactive WebGL): :func:`meshcat_scene`, :func:`update_scene`, :func:`static_html` /
  :func:`notebook_html` (self-contained HTML, works offline: nothing fetched from a CDN).
  :func:`meshcat_visualizer` creates a ``meshcat.Visualizer`` and, as meshcat 0.3.2's
  ``close()`` is broken, stops its zmq server process itself. Never call ``vis.get_image()``
  (hangs without a connected browser). The live viewer of a notebook (an iframe to a server on
  the kernel's loopback) is :mod:`lab.viz.live`, not meshcat's ``jupyter_cell()``.
* matplotlib: :func:`plot_arm` on a 3-D axes, :func:`plot_arm_views` for a 3-D view plus x-z
  (side) and y-z (front) projections, in centimetres.

Cables are coloured by their motor command u in [0, u_max] rad (like Fig. 2 of the paper)
when ``u_motor`` is given, else drawn in a neutral grey.
"""

from __future__ import annotations

import contextlib
import io
import warnings
from dataclasses import dataclass

import numpy as np

FOAM_RGB = (0.95, 0.72, 0.30)  # warm foam yellow-orange
CABLE_RGB = (0.25, 0.25, 0.25)  # cables without a command
TIP_RGB = (0.85, 0.10, 0.10)
CMAP = "cool"  # cyan (u = 0) to magenta (u_max): both stand out on the foam
UNITS = {"m": 1.0, "cm": 100.0, "mm": 1000.0}


@dataclass(frozen=True)
class ArmGeometry:
    """Drawable geometry in frame W, metres: node positions ``nodes_W`` (N, 3),
    outward-wound surface ``triangles`` (F, 3) indexing ``nodes_W``, one polyline
    (K+1, 3) per cable in ``cables_W`` (anchor, then via points), tip ``tip_W`` (3,)."""

    nodes_W: np.ndarray
    triangles: np.ndarray
    cables_W: list
    tip_W: np.ndarray


def arm_geometry(fem, q=None) -> ArmGeometry:
    """Geometry of ``fem`` at free coordinates ``q``.

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM (:class:`lab.fem.model.ArmFEM`).
    q : array_like, shape (n_free,), optional
        Free coordinates (m); None is the rest shape.

    Returns
    -------
    ArmGeometry
        Nodes, surface triangles, cable polylines and tip (m, frame W).
    """
    x = fem.X_W.copy() if q is None else fem.to_nodes(np.asarray(q, float))
    return ArmGeometry(x, fem.mesh.surface_triangles(), [c.points(x) for c in fem.cables], fem.tip(x))


def cable_colors(n_cables: int, u_motor=None, u_max: float = 1.0, cmap: str = CMAP) -> np.ndarray:
    """RGB colours of the cables: ``u_motor`` mapped by ``cmap`` over [0, ``u_max``] rad, or
    :data:`CABLE_RGB` for every cable if None.

    Parameters
    ----------
    n_cables : int
        Number of cables.
    u_motor : array_like, shape (n_cables,), optional
        Motor commands (rad).
    u_max, cmap : float, str, optional
        The command (rad) at the top of the matplotlib colour map ``cmap``.

    Returns
    -------
    numpy.ndarray, shape (n_cables, 3)
        RGB in [0, 1].
    """
    if u_motor is None:
        return np.tile(CABLE_RGB, (n_cables, 1))
    import matplotlib

    u = np.clip(np.asarray(u_motor, float) / u_max, 0.0, 1.0)
    return np.asarray(matplotlib.colormaps[cmap](u))[:, :3]


def _meshcat():
    """``import meshcat``, hiding the DeprecationWarning its server module raises."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import meshcat
        import meshcat.geometry
        import meshcat.transformations
    return meshcat


def _hex(rgb) -> int:
    return int.from_bytes(bytes(int(round(255 * c)) for c in rgb[:3]), "big")


# ------------------------------------------------------------------------- meshcat
@contextlib.contextmanager
def meshcat_visualizer():
    """``with meshcat_visualizer() as vis:`` a fresh ``meshcat.Visualizer`` (own zmq
    server subprocess on 127.0.0.1), always stopped on exit.

    Yields
    ------
    meshcat.Visualizer
        The visualizer, stopped (:func:`stop_visualizer`) when the block ends.
    """
    with contextlib.redirect_stdout(io.StringIO()):  # it prints its URL
        vis = _meshcat().Visualizer()
    try:
        yield vis
    finally:
        stop_visualizer(vis)


def stop_visualizer(vis) -> None:
    """Stop the server subprocess that ``meshcat.Visualizer()`` started (instead of
    the broken ``vis.close()``) and close the client socket.

    Parameters
    ----------
    vis : meshcat.Visualizer
        A visualizer that started its own server.
    """
    proc = vis.window.server_proc
    vis.window.zmq_socket.close(linger=0)
    if proc is not None and proc.poll() is None:
        proc.kill()
    if proc is not None:
        proc.wait()
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()


def set_view(
    vis, camera_W=(0.06, -0.26, 0.08), background_rgb=(1.0, 1.0, 1.0), grid: bool = False, axes: bool = False
) -> None:
    """Camera at ``camera_W``, looking at the origin (the base; meshcat 0.3.2 orbits about
    the world origin), a uniform background, grid/axes on or off.

    Parameters
    ----------
    vis : meshcat.Visualizer
        The scene.
    camera_W, background_rgb : sequence of float, shape (3,), optional
        Camera position (m, world frame); background colour (RGB in [0, 1]).
    grid, axes : bool, optional
        Show meshcat's grid and axes.
    """
    x, y, z = camera_W  # the default camera sits in a frame rotated +90 deg about x
    vis["/Cameras/default/rotated/<object>"].set_property("position", [x, z, -y])
    vis["/Background"].set_property("top_color", list(background_rgb))
    vis["/Background"].set_property("bottom_color", list(background_rgb))
    vis["/Grid"].set_property("visible", grid)
    vis["/Axes"].set_property("visible", axes)


def update_scene(
    vis, fem, q=None, u_motor=None, *, prefix: str = "arm", u_max: float | None = None, foam_opacity: float = 0.4
) -> ArmGeometry:
    """Draw (or redraw) the arm at ``q`` under ``vis[prefix]``: foam surface, cables
    coloured by ``u_motor`` (rad, over [0, ``u_max``], default the robot's u_max),
    tip sphere. Every call sets the geometry anew. Returns the geometry drawn."""
    g, tf = _meshcat().geometry, _meshcat().transformations
    geo = arm_geometry(fem, q)
    root = vis[prefix]
    root["foam"].set_object(
        g.TriangularMeshGeometry(geo.nodes_W, geo.triangles),
        g.MeshLambertMaterial(color=_hex(FOAM_RGB), opacity=foam_opacity),
    )
    u_max = fem.robot.u_max_rad if u_max is None else u_max
    colors = cable_colors(len(geo.cables_W), u_motor, u_max)
    for route, pts, rgb in zip(fem.robot.cables, geo.cables_W, colors):
        root["cables"][route.name].set_object(
            g.Line(
                g.PointsGeometry(np.ascontiguousarray(pts.T, dtype=np.float32)), g.LineBasicMaterial(color=_hex(rgb))
            )
        )  # WebGL lines are 1 px wide
    root["tip"].set_transform(tf.translation_matrix(geo.tip_W))
    return geo


def meshcat_scene(
    fem,
    q=None,
    vis=None,
    u_motor=None,
    *,
    prefix: str = "arm",
    view: bool = True,
    tip_radius_m: float = 0.004,
    **kwargs,
):
    """Draw the arm at ``q`` in ``vis`` (a new ``meshcat.Visualizer`` if None: stop
    it with :func:`stop_visualizer`).

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM.
    q, u_motor : array_like, shapes (n_free,), (m,), optional
        Free coordinates (m; None: rest); motor commands (rad) that colour the cables.
    vis : meshcat.Visualizer, optional
        The scene (None: a new visualizer).
    prefix, tip_radius_m : str, float, optional
        The scene path of the drawing; the tip sphere's radius (m).
    view : bool, optional
        Also apply :func:`set_view` (white background, no grid/axes, camera framing the
        20 cm arm from the front-left).
    **kwargs
        Go to :func:`update_scene`.

    Returns
    -------
    meshcat.Visualizer
        ``vis`` (or the new one).
    """
    meshcat = _meshcat()
    if vis is None:
        with contextlib.redirect_stdout(io.StringIO()):
            vis = meshcat.Visualizer()
    if view:
        set_view(vis)
    g = meshcat.geometry
    vis[prefix]["tip"].set_object(g.Sphere(tip_radius_m), g.MeshLambertMaterial(color=_hex(TIP_RGB)))
    update_scene(vis, fem, q, u_motor, prefix=prefix, **kwargs)
    return vis


def static_html(vis) -> str:
    """The whole scene as one self-contained HTML document (meshcat JS embedded, no
    network needed), e.g. to write to a file. For a notebook cell use :func:`notebook_html`.

    Parameters
    ----------
    vis : meshcat.Visualizer
        The scene.

    Returns
    -------
    str
        The HTML document.
    """
    return vis.static_html()


def notebook_html(vis, height_px: int = 400) -> str:
    """:func:`static_html` wrapped in an ``<iframe srcdoc>`` (what ``vis.render_static()``
    shows), for ``IPython.display.HTML``: safe on remote kernels, and its styles do not leak
    into the notebook page.

    Parameters
    ----------
    vis : meshcat.Visualizer
        The scene.
    height_px : int, optional
        The frame's height (pixels).

    Returns
    -------
    str
        The HTML of the frame.
    """
    return vis.render_static(height=height_px).data


# ------------------------------------------------------------------------- matplotlib
def plot_arm(
    ax,
    fem,
    q=None,
    u_motor=None,
    *,
    unit: str = "cm",
    dims=(0, 1, 2),
    u_max=None,
    foam_alpha: float = 0.25,
    linewidth: float = 2.0,
    geometry: ArmGeometry | None = None,
):
    """Draw the arm at ``q`` on ``ax``: a 3-D axes or, with two ``dims``, its projection on a
    2-D axes. Sets equal aspect. On a 3-D axes made with ``computed_zorder=False`` the cables
    and tip stay on top of the foam.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        A 3-D axes (``dims`` = (0, 1, 2)) or a 2-D one (two ``dims`` such as (0, 2)).
    fem : ArmFEM
        The arm's FEM.
    q, u_motor : array_like, shapes (n_free,), (m,), optional
        Free coordinates (m; None: rest); motor commands (rad) colouring the cables over
        [0, ``u_max``] (None: grey).
    unit, dims : str, sequence of int, optional
        Unit of the coordinates ("m", "cm" or "mm"); world axes drawn (0 = x, 1 = y, 2 = z).
    u_max : float, optional
        Top of the colour scale (rad; default the robot's u_max).
    foam_alpha, linewidth : float, optional
        The foam's opacity; the cables' line width (points).
    geometry : ArmGeometry, optional
        Geometry already computed at ``q`` (reused).

    Returns
    -------
    ArmGeometry
        The geometry drawn (m, frame W).
    """
    from matplotlib.collections import PolyCollection
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    geo = arm_geometry(fem, q) if geometry is None else geometry
    s, d = UNITS[unit], list(dims)
    tris = s * geo.nodes_W[geo.triangles][:, :, d]  # (F, 3, len(d))
    poly = (Poly3DCollection if len(d) == 3 else PolyCollection)(
        tris,
        facecolor=(*FOAM_RGB, foam_alpha),
        edgecolor=(*FOAM_RGB, min(1.0, 2 * foam_alpha)),
        linewidth=0.2,
        zorder=1,
    )
    ax.add_collection3d(poly) if len(d) == 3 else ax.add_collection(poly)
    u_max = fem.robot.u_max_rad if u_max is None else u_max
    for pts, rgb in zip(geo.cables_W, cable_colors(len(geo.cables_W), u_motor, u_max)):
        ax.plot(*(s * pts[:, d]).T, color=rgb, linewidth=linewidth, zorder=2)
    ax.plot(*(s * geo.tip_W[d, None]), "o", color=TIP_RGB, markersize=6, zorder=3)
    lo, hi = (s * geo.nodes_W[:, d]).min(0), (s * geo.nodes_W[:, d]).max(0)
    mid, half = (lo + hi) / 2, 0.55 * (hi - lo).max()
    for setter, m in zip((ax.set_xlim, ax.set_ylim, getattr(ax, "set_zlim", None)), mid):
        setter(m - half, m + half)
    ax.set_aspect("equal")
    names = "xyz"
    ax.set_xlabel(f"{names[d[0]]} [{unit}]")
    ax.set_ylabel(f"{names[d[1]]} [{unit}]")
    if len(d) == 3:
        ax.set_zlabel(f"{names[d[2]]} [{unit}]")
    return geo


def plot_arm_views(fem, q=None, u_motor=None, *, unit: str = "cm", u_max=None, figsize=(13, 4.5)):
    """Figure with a 3-D view, the x-z side view and the y-z front view of the arm at ``q``,
    plus a colour bar of the motor command when ``u_motor`` is given.

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM.
    q, u_motor : array_like, shapes (n_free,), (m,), optional
        Free coordinates (m; None: rest); motor commands (rad) that colour the cables.
    unit : str, optional
        Unit of the axes ("m", "cm", "mm").
    u_max : float, optional
        Top of the colour scale (rad; default the robot's u_max).
    figsize : tuple of float, optional
        Figure size (inches).

    Returns
    -------
    tuple
        ``(fig, (ax3d, ax_xz, ax_yz))``: the matplotlib Figure and its three axes.
    """
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    geo = arm_geometry(fem, q)
    fig = plt.figure(figsize=figsize, layout="constrained")
    grid = fig.add_gridspec(1, 3, width_ratios=(1.3, 1, 1))
    ax3 = fig.add_subplot(grid[0], projection="3d", computed_zorder=False)
    ax_xz, ax_yz = fig.add_subplot(grid[1]), fig.add_subplot(grid[2])
    for ax, dims, title in (
        (ax3, (0, 1, 2), "3-D view"),
        (ax_xz, (0, 2), "side view (x-z)"),
        (ax_yz, (1, 2), "front view (y-z)"),
    ):
        plot_arm(ax, fem, q, u_motor, unit=unit, dims=dims, u_max=u_max, geometry=geo)
        ax.set_title(title)
    ax3.set_proj_type("ortho")  # no perspective: lengths compare across the view
    ax3.set_box_aspect((1, 1, 1), zoom=0.85)  # equal: plot_arm made the limits a cube
    ax3.locator_params(nbins=4)
    if u_motor is not None:
        u_max = fem.robot.u_max_rad if u_max is None else u_max
        fig.colorbar(
            ScalarMappable(Normalize(0.0, u_max), CMAP),
            ax=[ax3, ax_xz, ax_yz],
            label="motor command u [rad]",
            shrink=0.8,
        )
    return fig, (ax3, ax_xz, ax_yz)
