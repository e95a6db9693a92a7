"""Still images of the 3-D scenes, for where no browser runs meshcat: a saved notebook, the
documentation site's recorded runs.

A meshcat scene that works offline is about a megabyte of HTML (its JavaScript embedded),
too much for a recorded run (``scripts/record_notebooks.py`` leaves out any representation
of an output over 200 kB). So :func:`lab.viz.show_arm` and :func:`lab.viz.show_animation`
return, beside the scene, a small PNG of it: :func:`lab.viz.arm_still` draws the arm with
matplotlib from meshcat's camera, :func:`lab.viz.animation_still` the animation as an
animated PNG (APNG: every current browser plays it; a viewer that cannot shows its first
frame). A :class:`lab.viz.SceneView` carries both: a Jupyter front end shows the scene (HTML
ranks above PNG), a page that cannot run it (the site) the still.

The drawings use a :class:`matplotlib.figure.Figure` of their own, never pyplot, so a
kernel's inline backend shows no second copy of them.
"""

from __future__ import annotations

import inspect
import io

import numpy as np

from lab.errors import InputError
from lab.viz.animation import ACHIEVED_RGB, TARGET_RGB
from lab.viz.arm import arm_geometry, plot_arm, set_view

__all__ = ["SceneView", "arm_still", "animation_still", "view_angles", "STILL_FRAMES", "STILL_BYTES"]

#: At most this many frames in an animated still (every k-th state is drawn).
STILL_FRAMES = 24
#: An animated still over this many bytes loses every other frame until it is not: with
#: base64's third more, it stays under the recorded runs' 200 kB per output.
STILL_BYTES = 140_000


def view_angles(camera_W=None) -> tuple[float, float]:
    """matplotlib's ``(elev, azim)`` (degrees) for a camera at ``camera_W`` looking at the origin.

    Parameters
    ----------
    camera_W : array_like, shape (3,), optional
        Camera position (m, world frame; default: that of :func:`lab.viz.arm.set_view`, the
        static snapshots' camera).

    Returns
    -------
    tuple of float
        Elevation and azimuth in degrees.
    """
    if camera_W is None:
        camera_W = inspect.signature(set_view).parameters["camera_W"].default
    x, y, z = np.asarray(camera_W, float)
    return float(np.degrees(np.arctan2(z, np.hypot(x, y)))), float(np.degrees(np.arctan2(y, x)))


def _figure(size_px, dpi):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(size_px[0] / dpi, size_px[1] / dpi), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.02, 0.02, 0.96, 0.93), projection="3d", computed_zorder=False)
    return fig, ax


def _cube(points_cm) -> tuple[np.ndarray, float]:
    lo, hi = points_cm.min(0), points_cm.max(0)
    return (lo + hi) / 2, 0.55 * float((hi - lo).max())


def _draw(ax, fem, q, u_motor, mid, half, camera_W, u_max=None):
    ax.cla()
    plot_arm(ax, fem, q, u_motor, u_max=u_max, linewidth=1.5)
    for setter, m in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid):
        setter(m - half, m + half)
    ax.set_box_aspect((1, 1, 1), zoom=1.0)
    ax.view_init(*view_angles(camera_W))
    ax.locator_params(nbins=4)
    ax.tick_params(labelsize=7, pad=0)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.label.set_size(8)
        axis.labelpad = -2


def _rgb(fig) -> np.ndarray:
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()


def arm_still(fem, q=None, u_motor=None, *, camera_W=None, size_px=(520, 420), dpi: int = 80) -> bytes:
    """The arm at ``q`` in 3-D, seen from ``camera_W``, as PNG bytes.

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM.
    q, u_motor : array_like, shapes (n_free,), (m,), optional
        Free coordinates (m; None: rest); motor commands (rad) colouring the cables (None: grey).
    camera_W : array_like, shape (3,), optional
        Camera position (m; default :func:`lab.viz.arm.set_view`'s).
    size_px : tuple of int, optional
        Width and height of the image (pixels).
    dpi : int, optional
        Resolution: sets the size of the text (the title) against the image.

    Returns
    -------
    bytes
        The PNG (tens of kilobytes).
    """
    from PIL import Image

    fig, ax = _figure(size_px, dpi)
    mid, half = _cube(100 * arm_geometry(fem, q).nodes_W)
    _draw(ax, fem, q, u_motor, mid, half, camera_W)
    if u_motor is not None:
        fig.suptitle("u = [" + ", ".join(f"{v:.2f}" for v in np.ravel(u_motor)) + "] rad", fontsize=9)
    buf = io.BytesIO()
    Image.fromarray(_rgb(fig)).quantize(colors=128, dither=Image.Dither.NONE).save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def animation_still(
    fem,
    q_frames,
    u_frames=None,
    *,
    targets_W=None,
    fps: float = 8.0,
    max_frames: int = STILL_FRAMES,
    max_bytes: int = STILL_BYTES,
    camera_W=None,
    size_px=(440, 360),
    dpi: int = 80,
) -> bytes:
    """The arm moving through ``q_frames`` in 3-D, as an animated PNG (APNG) that loops.

    Every k-th frame is drawn, so that at most ``max_frames`` are, each shown for ``k / fps``
    seconds (the animation keeps its length), and fewer if the file would exceed
    ``max_bytes``. With ``targets_W`` the target path is drawn in black and the tip's path so
    far in pink, as in the meshcat animation.

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM.
    q_frames : array_like, shape (T, n_free)
        Free coordinates per frame (m).
    u_frames : array_like, shape (T, m), optional
        Commands (rad) that colour the cables (None: grey).
    targets_W : array_like, shape (T, 3), optional
        The target of each frame (m, world frame).
    fps : float, optional
        Frames per second of ``q_frames``.
    max_frames : int, optional
        The most frames drawn (>= 1).
    max_bytes : int, optional
        The largest file: over it, every other frame is left out (each shown twice as long)
        until it fits or one frame is left.
    camera_W : array_like, shape (3,), optional
        Camera position (m; default :func:`lab.viz.arm.set_view`'s).
    size_px : tuple of int, optional
        Width and height of the image (pixels).
    dpi : int, optional
        Resolution: sets the size of the text against the image.

    Returns
    -------
    bytes
        The APNG.
    """
    from PIL import Image

    q_frames = np.atleast_2d(np.asarray(q_frames, float))
    n = len(q_frames)
    for name, a in (("u_frames", u_frames), ("targets_W", targets_W)):
        if a is not None and len(a) != n:
            raise InputError(f"{name} has {len(a)} rows for {n} frames")
    if n == 0 or max_frames < 1 or not fps > 0:
        raise InputError(f"an animated still needs frames ({n}), max_frames >= 1 ({max_frames}) and fps > 0 ({fps})")
    step = -(-n // max_frames)
    shown = range(0, n, step)
    tips = np.array([arm_geometry(fem, q).tip_W for q in q_frames])
    every = np.vstack([arm_geometry(fem, q_frames[k]).nodes_W for k in shown] + [tips])
    if targets_W is not None:
        targets_W = np.asarray(targets_W, float)
        every = np.vstack([every, targets_W])
    mid, half = _cube(100 * every)
    fig, ax = _figure(size_px, dpi)
    frames = []
    for k in shown:
        _draw(ax, fem, q_frames[k], None if u_frames is None else u_frames[k], mid, half, camera_W)
        if targets_W is not None:
            ax.plot(*(100 * targets_W).T, color=TARGET_RGB, linewidth=0.8, zorder=4)
            ax.plot(*(100 * tips[: k + 1]).T, color=ACHIEVED_RGB, linewidth=1.5, zorder=5)
            ax.plot(*(100 * targets_W[k, :, None]), "o", color=TARGET_RGB, markersize=4, zorder=6)
        frames.append(Image.fromarray(_rgb(fig)))
    # One palette for every frame, no dithering: the frames differ only where the arm moved,
    # so Pillow stores each as the box that changed. Over max_bytes, every other frame goes.
    palette = frames[len(frames) // 2].quantize(colors=128, dither=Image.Dither.NONE)
    frames = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    while True:
        buf = io.BytesIO()
        duration_ms = 1000 * step / fps
        frames[0].save(buf, "PNG", save_all=True, append_images=frames[1:], duration=duration_ms, loop=0, optimize=True)
        if buf.tell() <= max_bytes or len(frames) == 1:
            return buf.getvalue()
        frames, step = frames[::2], 2 * step


class SceneView:
    """A 3-D scene as a notebook output: its HTML (``data``) and a still PNG of it (``png``).

    A Jupyter front end shows the HTML; where HTML is dropped or cannot run (the site's
    recorded runs) the PNG stands in.

    Parameters
    ----------
    html : str
        The scene: a self-contained page in an iframe (:func:`lab.viz.arm.notebook_html`,
        :func:`lab.viz.animation.notebook_iframe`).
    png : bytes
        The still (:func:`lab.viz.arm_still`, :func:`lab.viz.animation_still`).
    what : str, optional
        What the scene shows, for the plain-text form.
    """

    def __init__(self, html: str, png: bytes, what: str = "a 3-D scene"):
        self.data, self.png, self.what = html, png, what

    def _repr_html_(self) -> str:
        return self.data

    def _repr_png_(self) -> bytes:
        return self.png

    def __repr__(self) -> str:
        return f"<{self.what}: {len(self.data) / 1e6:.1f} MB of HTML (meshcat), with a PNG still>"
