"""A meshcat animation of the arm following a trajectory, as self-contained HTML.

meshcat animates the transforms and properties of scene objects, not vertex positions, so
the arm is built from rigid pieces whose transforms carry the deformation (frame W,
metres): the foam body as a chain of scaled unit cylinders along the deformed centreline;
each cable as one thin cylinder per segment, coloured by its motor command through
``n_color_levels`` copies whose visibility is animated; the tip marker (red sphere), the
moving target (pink sphere), the target path (pink line) and the achieved tip path
(near-black line), in the colours of every figure (:mod:`lab.viz.style`).

:func:`animation_html` returns the page (meshcat's JavaScript embedded, no network needed);
show it in a notebook with ``IPython.display.HTML(notebook_iframe(html))``. It costs about
180 bytes per piece and frame on top of about 1.2 MB: pass fewer frames for long trajectories.
Why visibility and not a colour track, and the page size measured: docs/design/viz.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError
from lab.fem.bodies.mesh import barycentric
from lab.viz.arm import (
    FOAM_RGB,
    TIP_RGB,
    _hex,
    _meshcat,
    cable_colors,
    meshcat_visualizer,
    set_view,
)

TARGET_RGB = (0.890, 0.467, 0.761)  # lab.viz.style.TARGET_COLOR: pink, as in every figure
ACHIEVED_RGB = (0.15, 0.15, 0.15)  # lab.viz.style.ACHIEVED_COLOR: near-black
CABLE_RADIUS_M = 0.0012
MARKER_RADIUS_M = 0.004


# ------------------------------------------------------------------ geometry
def centreline_embedding(fem, n_segments: int = 20):
    """Barycentric embedding of ``n_segments`` + 1 equally spaced points on the body axis
    (x from 0 to length, y = z = 0) in the rest mesh. Embedded points move with the FEM
    interpolation, so this works for any tet mesh containing the axis and any ``n_segments``
    (no need to find cross-sections).

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM.
    n_segments : int, optional
        Number of axis segments S (>= 1).

    Returns
    -------
    tuple of numpy.ndarray
        Nodes (S+1, 4) int and weights (S+1, 4) of the containing tets.
    """
    if int(n_segments) != n_segments or n_segments < 1:
        raise InputError(f"n_segments must be a positive integer, got {n_segments!r}")
    x = np.linspace(0.0, fem.robot.length_m, int(n_segments) + 1)
    return barycentric(fem.mesh, np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]))


def centreline(fem, q=None, n_segments: int = 20, embedding=None) -> np.ndarray:
    """Deformed body axis (n_segments + 1, 3) in metres, base to tip, at free
    coordinates ``q`` (n_free,) (None: rest)."""
    nodes, weights = centreline_embedding(fem, n_segments) if embedding is None else embedding
    x = fem.X_W if q is None else fem.to_nodes(np.asarray(q, float))
    return np.einsum("sk,skd->sd", weights, x[nodes])


def rotation_from_y(d) -> np.ndarray:
    """Minimal rotation R (3, 3) with R e_y = d / |d| (meshcat/three.js cylinders lie
    along y). Minimal rotations change smoothly with d, so interpolating between
    frames does not twist the pieces; d antiparallel to y turns about x."""
    d = np.asarray(d, float) / np.linalg.norm(d)
    v, c = np.cross([0.0, 1.0, 0.0], d), d[1]
    if c < -1 + 1e-6:  # 1/(1+c) would lose accuracy: mirror the problem by pi about x
        return np.diag([1.0, -1.0, -1.0]) @ rotation_from_y(d * [1, -1, -1])
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K / (1 + c)


def segment_transforms(points, radius_m: float) -> np.ndarray:
    """Transforms (P-1, 4, 4) mapping the unit cylinder (radius 1, height 1, centred
    on the origin along y) onto the segments between consecutive ``points`` (P, 3) m:
    rotation and scale diag(r, length, r), then translation to the midpoint. So the
    unit cylinder's end points (0, -1/2, 0) and (0, 1/2, 0) map to points[i], points[i+1]."""
    p = np.asarray(points, float)
    T = np.tile(np.eye(4), (len(p) - 1, 1, 1))
    for i, (a, b) in enumerate(zip(p[:-1], p[1:])):
        length = np.linalg.norm(b - a)
        R = rotation_from_y(b - a) if length > 0 else np.eye(3)
        T[i, :3, :3] = R * [radius_m, length, radius_m]  # R @ diag(r, L, r)
        T[i, :3, 3] = (a + b) / 2
    return T


def end_caps(body) -> np.ndarray:
    """Transforms (2, ..., 4, 4) of the unit cylinder as the thin discs (0.1 mm) that close
    the open body tube at its base and its tip, from the body pieces ``body`` (S, ..., 4, 4)."""
    caps = np.array([body[0], body[-1]])
    for cap, end in zip(caps, (-0.5, 0.5)):
        axis = cap[..., :3, 1].copy()
        cap[..., :3, 3] += end * axis  # centred on the axis end
        cap[..., :3, 1] *= 1e-4 / np.linalg.norm(axis, axis=-1, keepdims=True)
    return caps


@dataclass(frozen=True)
class ArmPieces:
    """Transforms (4, 4) of the unit cylinders that draw the arm in one frame.

    Attributes
    ----------
    body : numpy.ndarray, shape (S, 4, 4)
        The body's segments.
    cables : list of numpy.ndarray
        One (K, 4, 4) array per cable.
    tip_W : numpy.ndarray, shape (3,)
        The tip marker (m, world frame).
    """

    body: np.ndarray
    cables: list
    tip_W: np.ndarray


def arm_pieces(
    fem, q=None, n_segments: int = 20, *, cable_radius_m: float = CABLE_RADIUS_M, embedding=None
) -> ArmPieces:
    """The rigid pieces of the arm at ``q``.

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM.
    q : array_like, shape (n_free,), optional
        Free coordinates (m; None: rest).
    n_segments : int, optional
        Body segments S.
    cable_radius_m : float, optional
        Radius of the cable cylinders (m).
    embedding : tuple, optional
        :func:`centreline_embedding`'s result, reused across frames.

    Returns
    -------
    ArmPieces
        The transforms of the body, cable and tip pieces.
    """
    x = fem.X_W if q is None else fem.to_nodes(np.asarray(q, float))
    axis = centreline(fem, q, n_segments, embedding)
    return ArmPieces(
        segment_transforms(axis, fem.robot.radius_m),
        [segment_transforms(c.points(x), cable_radius_m) for c in fem.cables],
        fem.tip(x),
    )


# ------------------------------------------------------------------ animation
def _check_frames(name, a, shape) -> np.ndarray:
    a = np.asarray(a, float)
    if a.ndim != 2 or a.shape[1] != shape[1] or len(a) == 0 or shape[0] not in (None, len(a)):
        want = f"({'T' if shape[0] is None else shape[0]}, {shape[1]})"
        raise InputError(f"{name} must have shape {want}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} has non-finite values (frames {np.flatnonzero(~np.isfinite(a).all(1))[:5].tolist()})")
    return a


def _quaternion_xyzw(R) -> list:
    """Quaternion [x, y, z, w] (three.js order) of a rotation matrix (3, 3)."""
    M = np.eye(4)
    M[:3, :3] = R
    w, x, y, z = _meshcat().transformations.quaternion_from_matrix(M)
    return [float(x), float(y), float(z), float(w)]


def _unit_cylinder(radial_segments: int, open_ended: bool):
    """meshcat ``Cylinder`` of radius 1 and height 1 along y, with the three.js
    options meshcat does not expose (facets around, no end discs)."""

    class UnitCylinder(_meshcat().geometry.Cylinder):
        def lower(self, object_data):
            return {**super().lower(object_data), "radialSegments": radial_segments, "openEnded": open_ended}

    return UnitCylinder(1.0, 1.0)


def _key_transform(frame, T, position_only: bool = False) -> None:
    """Animate a piece to T (4, 4): position, quaternion and scale as three tracks
    (meshcat's frame.set_transform keeps no scale and takes the quaternion of R S)."""
    frame.set_property("position", "vector3", T[:3, 3].tolist())
    if position_only:  # markers: a sphere needs no turning
        return
    s = np.linalg.norm(T[:3, :3], axis=0)
    frame.set_property("quaternion", "quaternion", _quaternion_xyzw(T[:3, :3] / np.where(s > 0, s, 1)))
    frame.set_property("scale", "vector3", s.tolist())


def animate_arm(
    vis,
    fem,
    q_frames,
    u_frames=None,
    *,
    targets_W=None,
    fps: float = 10.0,
    prefix: str = "anim",
    n_segments: int = 20,
    n_color_levels: int = 7,
    foam_opacity: float = 0.4,
    play: bool = True,
    repetitions: int = 1,
    paths: bool = True,
):
    """Draw the arm under ``vis[prefix]`` and animate it through the states ``q_frames``.

    The scene shows frame 0 until the animation runs; a single frame is drawn but not
    animated. Pieces under ``vis[prefix]``: ``body/00``.., ``body/base``, ``body/end``,
    ``cables/<name>/00``.. (colour levels ``u0``.. below them), ``tip``, ``target``,
    ``target_path``, ``tip_path``. Raises InputError on bad shapes or values.

    Parameters
    ----------
    vis : meshcat.Visualizer
        The scene.
    fem : ArmFEM
        The arm's FEM.
    q_frames : array_like, shape (T, n_free)
        Free coordinates per frame (m).
    u_frames : array_like, shape (T, m), optional
        Commands (rad) that colour each cable, rounded to one of ``n_color_levels`` levels
        over [0, u_max] (None: grey cables).
    targets_W : array_like, shape (T, 3), optional
        Adds a moving target sphere (m, world frame) and, with ``paths``, the target path
        (pink) and the achieved tip path (near-black) as lines.
    fps : float, optional
        Frames per second.
    prefix : str, optional
        The scene path of the drawing.
    n_segments : int, optional
        Cylinders of the body radius along the body.
    n_color_levels : int, optional
        Colour levels of the cables (>= 2).
    foam_opacity : float, optional
        The body's opacity (lets the cables inside show).
    play, repetitions : bool, int, optional
        Passed to ``vis.set_animation``.
    paths : bool, optional
        Draw the target and tip paths.

    Returns
    -------
    meshcat.animation.Animation
        The animation sent to ``vis``.
    """
    g = _meshcat().geometry
    from meshcat.animation import Animation

    q = _check_frames("q_frames", q_frames, (None, fem.n_free))
    n_frames = len(q)
    u = None if u_frames is None else _check_frames("u_frames", u_frames, (n_frames, fem.robot.n_inputs))
    targets = None if targets_W is None else _check_frames("targets_W", targets_W, (n_frames, 3))
    if not (np.isfinite(fps) and fps > 0):
        raise InputError(f"fps must be positive, got {fps!r}")
    if int(n_color_levels) != n_color_levels or n_color_levels < 2:
        raise InputError(f"n_color_levels must be an integer >= 2, got {n_color_levels!r}")

    embedding = centreline_embedding(fem, n_segments)
    pieces = [arm_pieces(fem, qi, n_segments, embedding=embedding) for qi in q]
    u_max = fem.robot.u_max_rad
    n_levels = 1 if u is None else int(n_color_levels)
    level_u = np.linspace(0.0, u_max, n_levels)
    colors = cable_colors(n_levels, None if u is None else level_u, u_max)
    # levels[t, c]: the colour level shown for cable c in frame t
    levels = (
        np.zeros((n_frames, fem.robot.n_inputs), int)
        if u is None
        else np.rint(np.clip(u / u_max, 0, 1) * (n_levels - 1)).astype(int)
    )

    root = vis[prefix]
    # The body segments are open tubes, closed by two thin discs at the base and tip:
    # transparent end discs at every joint would show as dark bands. Front faces only:
    # transparent double-sided tubes draw their two sides in triangle order (stripes).
    tube, disc, cable_geom = _unit_cylinder(48, True), _unit_cylinder(48, False), _unit_cylinder(12, False)
    body_mat = g.MeshLambertMaterial(color=_hex(FOAM_RGB), opacity=foam_opacity, side=0)
    level_mats = [g.MeshLambertMaterial(color=_hex(c)) for c in colors]
    moving = {}  # path -> (T, 4, 4) transforms over the frames
    body = np.array([p.body for p in pieces])  # (T, S, 4, 4)
    for i in range(body.shape[1]):
        root[f"body/{i:02d}"].set_object(tube, body_mat)
        moving[f"body/{i:02d}"] = body[:, i]
    caps = end_caps(body.transpose(1, 0, 2, 3))  # (2, T, 4, 4)
    for name, cap in zip(("base", "end"), caps):
        root[f"body/{name}"].set_object(disc, body_mat)
        moving[f"body/{name}"] = cap
    for c, route in enumerate(fem.robot.cables):
        for k in range(len(pieces[0].cables[c])):
            path = f"cables/{route.name}/{k:02d}"
            for j in range(n_levels):
                root[path][f"u{j}"].set_object(cable_geom, level_mats[j])
                root[path][f"u{j}"].set_property("visible", bool(levels[0, c] == j))
            moving[path] = np.array([p.cables[c][k] for p in pieces])
    markers = {"tip": (np.array([p.tip_W for p in pieces]), TIP_RGB)}
    if targets is not None:
        markers["target"] = (targets, TARGET_RGB)
    for name, (pos, rgb) in markers.items():
        root[name].set_object(g.Sphere(MARKER_RADIUS_M), g.MeshLambertMaterial(color=_hex(rgb)))
        moving[name] = np.tile(np.eye(4), (n_frames, 1, 1))
        moving[name][:, :3, 3] = pos
    if paths and targets is not None:
        for name, pts, rgb in (("target_path", targets, TARGET_RGB), ("tip_path", markers["tip"][0], ACHIEVED_RGB)):
            root[name].set_object(
                g.Line(g.PointsGeometry(np.ascontiguousarray(pts.T, np.float32)), g.LineBasicMaterial(color=_hex(rgb)))
            )

    anim = Animation(default_framerate=fps)
    for path, Ts in moving.items():
        root[path].set_transform(Ts[0])  # the still scene: frame 0
        for t, T in enumerate(Ts):
            _key_transform(anim.at_frame(root, t)[path], T, position_only=path in markers)
    for c, route in enumerate(fem.robot.cables):
        if n_levels == 1:
            break
        # Visibility only needs keys where it changes (boolean tracks are stepwise),
        # plus the last frame so that every clip lasts as long as the motion.
        change = np.flatnonzero(np.r_[True, levels[1:, c] != levels[:-1, c]])
        for k in range(len(pieces[0].cables[c])):
            for j in range(n_levels):
                for t in sorted({*change.tolist(), n_frames - 1}):
                    anim.at_frame(root, t)[f"cables/{route.name}/{k:02d}/u{j}"].set_property(
                        "visible", "boolean", bool(levels[t, c] == j)
                    )
    if n_frames > 1:  # a clip of duration 0 makes three.js wrap time to NaN
        vis.set_animation(anim, play=play, repetitions=repetitions)
    return anim


def animation_html(fem, q_frames, u_frames=None, *, targets_W=None, view: bool = True, camera_W=None, **kwargs) -> str:
    """Self-contained HTML page (meshcat JavaScript embedded, no network needed) of
    :func:`animate_arm`, from a fresh visualizer that is stopped afterwards.

    Parameters
    ----------
    fem, q_frames, u_frames, targets_W
        As :func:`animate_arm`'s.
    view : bool, optional
        White background, no grid/axes, camera at ``camera_W``.
    camera_W : array_like, shape (3,), optional
        Camera position (m, world frame; default: :func:`lab.viz.arm.set_view`'s).
    **kwargs
        Go to :func:`animate_arm`.

    Returns
    -------
    str
        The HTML page.
    """
    with meshcat_visualizer() as vis:
        if view:
            set_view(vis, **({} if camera_W is None else {"camera_W": camera_W}))
        animate_arm(vis, fem, q_frames, u_frames, targets_W=targets_W, **kwargs)
        return vis.static_html()


def notebook_iframe(page_html: str, height_px: int = 400) -> str:
    """``page_html`` in an ``<iframe srcdoc>`` for ``IPython.display.HTML``, as
    ``vis.render_static()`` wraps it: works on remote kernels and offline, and its
    styles stay out of the notebook page.

    Parameters
    ----------
    page_html : str
        A self-contained page (:func:`animation_html`).
    height_px : int, optional
        The frame's height (pixels; resizable).

    Returns
    -------
    str
        The HTML of the frame.
    """
    srcdoc_escape = _meshcat().visualizer.srcdoc_escape
    return (
        f'<div style="height: {height_px}px; width: 100%; overflow-x: auto; overflow-y: hidden; '
        f'resize: both"><iframe srcdoc="{srcdoc_escape(page_html)}" '
        f'style="width: 100%; height: 100%; border: none"></iframe></div>'
    )
