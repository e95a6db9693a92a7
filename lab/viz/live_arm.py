"""The arm in the live meshcat viewer (:mod:`lab.viz.live`), moved rather than redrawn.

:class:`LiveArm` sends the arm's rigid pieces once (``set_object``: the body tube as
segments, each cable as thin cylinders, the tip marker; the pieces of
:func:`lab.viz.animation.arm_pieces`) and then, per update, only their transforms and a
cable's colour when its command's colour changes: a slider move is about 50 small
messages (under 10 ms), not a new scene, and a page opened later gets the current pose.

:func:`show_arm` and :func:`show_animation` are what the chapters call: in an interactive
front end they draw in this kernel's live viewer and show its page in an iframe; elsewhere
(papermill, the docs, tests) they return the self-contained static HTML page as before, so
no run outside a live kernel starts a server.
"""

from __future__ import annotations

import numpy as np

from lab.viz.animation import (
    CABLE_RADIUS_M,
    MARKER_RADIUS_M,
    _unit_cylinder,
    arm_pieces,
    centreline_embedding,
    end_caps,
)
from lab.viz.arm import CABLE_RGB, FOAM_RGB, TIP_RGB, _hex, _meshcat, cable_colors
from lab.viz.live import live_viewer, live_viewer_wanted

__all__ = ["LiveArm", "show_arm", "show_animation"]


class LiveArm:
    """The arm of ``fem`` drawn under ``vis[prefix]`` as rigid pieces (those of
    :func:`lab.viz.animation.arm_pieces`): the objects are sent once, here, and each
    :meth:`update` sends only their transforms and the cables' colours. Pieces:
    ``body/00``.., ``body/base``, ``body/end``, ``cables/<name>/00``.., ``tip``.

    Parameters
    ----------
    vis : meshcat.Visualizer
        The live viewer's scene (``LiveViewer.vis``, :mod:`lab.viz.live`).
    fem : ArmFEM
        The arm's FEM.
    prefix : str, optional
        The scene path of the arm (deleted and drawn anew).
    n_segments : int, optional
        Body segments.
    foam_opacity : float, optional
        The body's opacity.
    """

    def __init__(self, vis, fem, *, prefix: str = "arm", n_segments: int = 20, foam_opacity: float = 0.4):
        g = _meshcat().geometry
        self.vis, self.fem, self.prefix = vis, fem, prefix
        self.root = vis[prefix]
        self.root.delete()  # a cell run again draws a fresh arm
        self.embedding = centreline_embedding(fem, n_segments)
        tube, disc, cable = _unit_cylinder(48, True), _unit_cylinder(48, False), _unit_cylinder(12, False)
        body_mat = g.MeshLambertMaterial(color=_hex(FOAM_RGB), opacity=foam_opacity, side=0)
        for i in range(n_segments):
            self.root[f"body/{i:02d}"].set_object(tube, body_mat)
        for name in ("base", "end"):
            self.root[f"body/{name}"].set_object(disc, body_mat)
        self.cable_paths = [
            [f"cables/{route.name}/{k:02d}" for k in range(len(route.via_points_m))] for route in fem.robot.cables
        ]
        for paths in self.cable_paths:
            for path in paths:
                self.root[path].set_object(cable, g.MeshLambertMaterial(color=_hex(CABLE_RGB)))
        self.root["tip"].set_object(g.Sphere(MARKER_RADIUS_M), g.MeshLambertMaterial(color=_hex(TIP_RGB)))
        self._colors = [None] * fem.robot.n_inputs
        self.update()

    def update(self, q=None, u_motor=None):
        """Move the arm to free coordinates ``q`` (None: rest), cables coloured by ``u_motor``
        (None: grey).

        Parameters
        ----------
        q : array_like, shape (n_free,), optional
            Free coordinates (m).
        u_motor : array_like, shape (n_cables,), optional
            Motor commands (rad).

        Returns
        -------
        ArmPieces
            The pieces drawn (:class:`lab.viz.animation.ArmPieces`; ``tip_W`` (3,) m).
        """
        n_segments = len(self.embedding[0]) - 1
        pieces = arm_pieces(self.fem, q, n_segments, cable_radius_m=CABLE_RADIUS_M, embedding=self.embedding)
        for i, T in enumerate(pieces.body):
            self.root[f"body/{i:02d}"].set_transform(T)
        for name, T in zip(("base", "end"), end_caps(pieces.body)):
            self.root[f"body/{name}"].set_transform(T)
        colors = cable_colors(self.fem.robot.n_inputs, u_motor, self.fem.robot.u_max_rad)
        for c, (paths, Ts) in enumerate(zip(self.cable_paths, pieces.cables)):
            rgba = [*np.round(colors[c], 3).tolist(), 1.0]
            for path, T in zip(paths, Ts):
                self.root[path].set_transform(T)
                if rgba != self._colors[c]:  # only when the command's colour changes
                    self.root[path].set_property("color", rgba)
            self._colors[c] = rgba
        T_tip = np.eye(4)
        T_tip[:3, 3] = pieces.tip_W
        self.root["tip"].set_transform(T_tip)
        return pieces


def show_arm(fem, q=None, u_motor=None, *, live: bool | None = None, prefix: str = "view", height_px: int = 400):
    """The arm at ``q``, cables coloured by ``u_motor``, as a notebook output: drawn in this
    kernel's live viewer under ``prefix`` when ``live``, else a self-contained static snapshot
    (meshcat's JavaScript embedded, works offline) with a still PNG of it beside
    (:func:`lab.viz.stills.arm_still`: what a page that runs no scene shows). Prints which.

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM.
    q : array_like, shape (n_free,), optional
        Free coordinates (m; None: rest).
    u_motor : array_like, shape (n_cables,), optional
        Motor commands (rad; None: grey cables).
    live : bool, optional
        Use the live viewer (None: :func:`live_viewer_wanted`).
    prefix : str, optional
        The arm's scene path in the live viewer.
    height_px : int, optional
        Height of the output (pixels).

    Returns
    -------
    IPython.display.HTML or SceneView
        The viewer's iframe, or the static page and its still (:class:`lab.viz.stills.SceneView`).
    """
    from lab.viz.arm import meshcat_scene, meshcat_visualizer, notebook_html
    from lab.viz.stills import SceneView, arm_still

    if live_viewer_wanted() if live is None else live:
        viewer = live_viewer()
        LiveArm(viewer.vis, fem, prefix=prefix).update(q, u_motor)
        viewer.focus(prefix)
        print(f"live viewer at {viewer.url}, served by this kernel")
        return viewer.show(height_px)
    with meshcat_visualizer() as vis:
        meshcat_scene(fem, q, vis, u_motor=u_motor)
        page = notebook_html(vis, height_px)
    still = arm_still(fem, q, u_motor)
    print(f"static snapshot: {len(page) / 1e6:.1f} MB of HTML, and a still image of it")
    return SceneView(page, still, "the arm in 3-D")


def show_animation(page_html: str, fem, q_frames, u_frames=None, *, live=None, prefix="anim", height_px=400, **kwargs):
    """:func:`lab.viz.animation.animation_html`'s animation as a notebook output: played by
    this kernel's live viewer when ``live``, else its page ``page_html`` in an iframe with an
    animated PNG of it beside (:func:`lab.viz.stills.animation_still`: what a page that runs
    no scene shows).

    Parameters
    ----------
    page_html : str
        The static page (:func:`lab.viz.animation.animation_html`).
    fem, q_frames, u_frames
        As :func:`lab.viz.animation.animate_arm`'s: the FEM, (T, n_free) m, (T, m) rad.
    live : bool, optional
        Use the live viewer (None: :func:`live_viewer_wanted`).
    prefix : str, optional
        The animation's scene path in the live viewer.
    height_px : int, optional
        Height of the output (pixels).
    **kwargs
        Go to :func:`lab.viz.animation.animate_arm` (live), or its ``targets_W`` and ``fps``
        to :func:`lab.viz.stills.animation_still` (static).

    Returns
    -------
    IPython.display.HTML or SceneView
        The viewer's iframe, or the static page's with its animated still
        (:class:`lab.viz.stills.SceneView`).
    """
    from lab.viz.animation import animate_arm, notebook_iframe
    from lab.viz.stills import SceneView, animation_still

    if not (live_viewer_wanted() if live is None else live):
        still = animation_still(fem, q_frames, u_frames, **{k: kwargs[k] for k in ("targets_W", "fps") if k in kwargs})
        return SceneView(notebook_iframe(page_html, height_px), still, "the animation in 3-D")
    viewer = live_viewer()
    viewer.vis[prefix].delete()
    animate_arm(viewer.vis, fem, q_frames, u_frames, prefix=prefix, **kwargs)
    viewer.focus(prefix)
    return viewer.show(height_px)
