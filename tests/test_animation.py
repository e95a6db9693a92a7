"""Tests of lab.viz.animation: the rigid pieces that carry the arm's deformation, the
meshcat animation built from them, and the page played in headless Chromium (driven over
the DevTools protocol, so that screenshots wait for the page's state, not for time)."""

import numpy as np
import pytest
from helpers import DevToolsPage
from test_viz import _pixel_counts, devtools_command, require_chromium

from lab.description import load_robot
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static
from lab.viz import animation as A
from lab.viz import arm as viz

U_UP = np.array([3.0, 0.0, 0.0])  # top cable at u_max: the arm bends up
ENDS = np.array([[0.0, -0.5, 0.0, 1.0], [0.0, 0.5, 0.0, 1.0]])  # unit cylinder's axis ends


@pytest.fixture(scope="module")
def bent_q(coarse_fem):
    return solve_static(coarse_fem, U_UP).q


@pytest.fixture(scope="module")
def six_fem():
    return ArmFEM(load_robot("six-cable"), n_rings=1, n_axial=6)


def _ends(T):
    """Where the transforms (P, 4, 4) put the unit cylinder's axis ends: (P, 2, 3)."""
    return np.einsum("pij,ej->pei", T, ENDS)[..., :3]


def test_rotation_from_y():
    rng = np.random.default_rng(0)
    dirs = [*rng.normal(size=(20, 3)), [0, 1, 0], [0, -1, 0], [1, 0, 0], [0, -1, 1e-9], [1e-5, -1, 0]]
    for d in dirs:
        R = A.rotation_from_y(np.multiply(d, 3.0))  # any length
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        np.testing.assert_allclose(R @ [0, 1, 0], d / np.linalg.norm(d), atol=1e-12)
    # Minimal: a vector along the rotation axis (y x d) stays put.
    np.testing.assert_allclose(A.rotation_from_y([1, 1, 0]) @ [0, 0, 1], [0, 0, 1], atol=1e-12)


def test_rest_body_is_straight_along_x(coarse_fem):
    fem, n = coarse_fem, 8
    p = A.arm_pieces(fem, None, n)
    L, r = fem.robot.length_m, fem.robot.radius_m
    x = np.linspace(0, L, n + 1)
    np.testing.assert_allclose(
        _ends(p.body),
        np.stack([np.column_stack([x, 0 * x, 0 * x])[:-1], np.column_stack([x, 0 * x, 0 * x])[1:]], 1),
        atol=1e-12,
    )
    np.testing.assert_allclose(p.body[:, :3, 1], np.tile([L / n, 0, 0], (n, 1)), atol=1e-12)  # y -> +x
    np.testing.assert_allclose(np.linalg.norm(p.body[:, :3, [0, 2]], axis=1), r)  # radius
    np.testing.assert_allclose(p.tip_W, fem.robot.p_tip_marker_W)


def test_pieces_follow_centreline_and_cables(coarse_fem, bent_q):
    fem, n = coarse_fem, 12
    x = fem.to_nodes(bent_q)
    axis = A.centreline(fem, bent_q, n)
    p = A.arm_pieces(fem, bent_q, n, cable_radius_m=0.002)
    # The body's unit cylinders end exactly on consecutive centreline points...
    np.testing.assert_allclose(_ends(p.body), np.stack([axis[:-1], axis[1:]], 1), atol=1e-12)
    lengths = np.linalg.norm(np.diff(axis, axis=0), axis=1)
    np.testing.assert_allclose(np.linalg.norm(p.body[:, :3, 1], axis=1), lengths)
    # ... with the body radius across, and no shear (orthogonal axes).
    G = np.einsum("pki,pkj->pij", p.body[:, :3, :3], p.body[:, :3, :3])
    np.testing.assert_allclose(
        G, np.array([np.diag([fem.robot.radius_m**2, l**2, fem.robot.radius_m**2]) for l in lengths]), atol=1e-15
    )
    # The centreline is the deformed axis: base clamped at the origin, the tip marker
    # (at the end-face centre) at its end, and at the mesh's layers the axis nodes.
    np.testing.assert_allclose(axis[0], 0, atol=1e-15)
    np.testing.assert_allclose(axis[-1], fem.tip(x), atol=1e-12)
    assert axis[-1, 2] > 0.05 and np.all(np.diff(axis[:, 2]) > -1e-4)  # bent upwards
    on_axis = np.flatnonzero(np.hypot(fem.X_W[:, 1], fem.X_W[:, 2]) < 1e-12)
    layers = A.centreline(fem, bent_q, len(on_axis) - 1)
    np.testing.assert_allclose(layers, x[on_axis[np.argsort(fem.X_W[on_axis, 0])]], atol=1e-12)
    # Each cable's pieces run along its polyline, anchor to tie-off.
    geo = viz.arm_geometry(fem, bent_q)
    for T, pts in zip(p.cables, geo.cables_W):
        assert T.shape == (len(pts) - 1, 4, 4)
        np.testing.assert_allclose(_ends(T), np.stack([pts[:-1], pts[1:]], 1), atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(T[:, :3, 0], axis=1), 0.002)


def _value_at(track, t):
    """Value of a meshcat AnimationTrack at frame t (keys are stepwise between frames)."""
    i = max(k for k, f in enumerate(track.frames) if f <= t)
    return track.values[i]


def _piece_matrix(clip, t):
    x, y, z, w = _value_at(clip.tracks["quaternion"], t)
    R = viz._meshcat().transformations.quaternion_matrix([w, x, y, z])[:3, :3]
    T = np.eye(4)
    T[:3, :3] = R * _value_at(clip.tracks["scale"], t)
    T[:3, 3] = _value_at(clip.tracks["position"], t)
    return T


@pytest.mark.parametrize("robot", ["three-cable", "six-cable"])
def test_animation_has_every_piece_in_every_frame(robot, coarse_fem, bent_q, six_fem):
    fem = coarse_fem if robot == "three-cable" else six_fem
    m = fem.robot.n_cables
    u = np.zeros((3, m))
    u[1, 0], u[2, 0], u[2, m - 1] = 1.4, 3.0, 1.0
    q = np.array([fem.rest_q(), solve_static(fem, u[1]).q, solve_static(fem, u[2]).q])
    targets = np.array([[0.2, 0.0, z] for z in (0.0, 0.03, 0.06)])
    n_seg, n_lev = 5, 4
    with viz.meshcat_visualizer() as vis:
        anim = A.animate_arm(vis, fem, q, u, targets_W=targets, fps=4, n_segments=n_seg, n_color_levels=n_lev)
    assert anim.default_framerate == 4 and all(clip.fps == 4 for clip in anim.clips.values())
    clips = {path.lower().split("/anim/")[1]: clip for path, clip in anim.clips.items()}
    routes = fem.robot.cables
    body = [f"body/{i:02d}" for i in range(n_seg)]
    cables = [f"cables/{c.name}/{k:02d}" for c in routes for k in range(len(c.via_points_m))]
    levels = [f"{p}/u{j}" for p in cables for j in range(n_lev)]
    assert set(clips) == {*body, "body/base", "body/end", *cables, *levels, "tip", "target"}
    for t in range(3):
        pieces = A.arm_pieces(fem, q[t], n_seg)
        for path, T in zip(body + cables, [*pieces.body, *np.concatenate(pieces.cables)]):
            assert {f for tr in clips[path].tracks.values() for f in tr.frames} == {0, 1, 2}
            np.testing.assert_allclose(_piece_matrix(clips[path], t), T, atol=1e-12)
        np.testing.assert_allclose(_value_at(clips["tip"].tracks["position"], t), pieces.tip_W)
        np.testing.assert_allclose(_value_at(clips["target"].tracks["position"], t), targets[t])
        # Exactly one colour level of each cable piece shows: the command's, rounded.
        for c, route in enumerate(routes):
            shown = [j for j in range(n_lev) if _value_at(clips[f"cables/{route.name}/00/u{j}"].tracks["visible"], t)]
            assert shown == [round(u[t, c] / fem.robot.u_max_rad * (n_lev - 1))], (t, route.name)
    assert [_value_at(clips[f"cables/{routes[0].name}/00/u3"].tracks["visible"], t) for t in range(3)] == [
        False,
        False,
        True,
    ]


def test_single_frame_without_commands_or_targets(coarse_fem, bent_q):
    with viz.meshcat_visualizer() as vis:
        anim = A.animate_arm(vis, coarse_fem, bent_q[None], n_segments=3)
        page = vis.static_html()
    clips = {path.lower().split("/anim/")[1]: clip for path, clip in anim.clips.items()}
    cables = {f"cables/{c.name}/{k:02d}" for c in coarse_fem.robot.cables for k in range(len(c.via_points_m))}
    assert set(clips) == {"body/00", "body/01", "body/02", "body/base", "body/end", "tip", *cables}
    assert all(f == [0] for clip in clips.values() for tr in clip.tracks.values() for f in [tr.frames])
    # Drawn, not animated (no set_animation command): object and transform of the 5
    # body pieces and the tip; per cable piece its transform, and the object and
    # visibility of its only (grey) colour level.
    assert page.count('fetch("data:') == 2 * 6 + 3 * len(cables)


def test_bad_input_raises(coarse_fem, bent_q):
    fem = coarse_fem
    q = np.array([fem.rest_q(), bent_q])
    nan_q = q.copy()
    nan_q[1, 5] = np.nan
    cases = [
        (dict(q_frames=q[:, :-1]), r"q_frames must have shape \(T, \d+\), got \(2, \d+\)"),
        (dict(q_frames=q[0]), "q_frames must have shape"),
        (dict(q_frames=q[:0]), "q_frames must have shape"),
        (dict(q_frames=nan_q), r"q_frames has non-finite values \(frames \[1\]\)"),
        (dict(u_frames=np.zeros((3, 3))), r"u_frames must have shape \(2, 3\), got \(3, 3\)"),
        (dict(u_frames=np.zeros((2, 6))), r"u_frames must have shape \(2, 3\)"),
        (dict(u_frames=[[0, 0, 0], [0, np.inf, 0]]), "u_frames has non-finite"),
        (dict(targets_W=np.zeros((2, 2))), r"targets_W must have shape \(2, 3\)"),
        (dict(targets_W=[[0, 0, 0], [0, 0, np.nan]]), "targets_W has non-finite"),
        (dict(fps=0.0), "fps must be positive"),
        (dict(fps=np.nan), "fps must be positive"),
        (dict(n_segments=0), "n_segments must be a positive integer"),
        (dict(n_segments=2.5), "n_segments must be a positive integer"),
        (dict(n_color_levels=1), "n_color_levels must be an integer >= 2"),
    ]
    with viz.meshcat_visualizer() as vis:
        for kwargs, match in cases:
            with pytest.raises(ValueError, match=match):
                A.animate_arm(vis, fem, **{"q_frames": q, **kwargs})


# ------------------------------------------------------------------ browser
def _red_centroid(img):
    """Row, column of the tip marker's red pixels, and how many there are."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    rows, cols = np.nonzero((r - g > 80) & (r - b > 80))
    return (rows.mean(), cols.mean(), len(rows)) if len(rows) else (np.nan, np.nan, 0)


_VIEWER = 'var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));'
_COUNT_COMMANDS = (
    "window.handled_commands = 0; { const handle = viewer.handle_command_bytearray.bind(viewer); "
    "viewer.handle_command_bytearray = b => { handle(b); window.handled_commands += 1; }; }"
)


def _load(page, html, path):
    """Open ``html`` in ``page`` and wait until its viewer has handled every scene command
    (the static page fetches them all at once, and they arrive in any order)."""
    assert html.count(_VIEWER) == 1
    path.write_text(html.replace(_VIEWER, _VIEWER + _COUNT_COMMANDS))
    page.navigate(path.as_uri())
    n = html.count('fetch("data:')
    page.wait_for(f"window.handled_commands === {n}", 120, f"the page to handle its {n} scene commands")


@pytest.mark.slow
@pytest.mark.browser
def test_animation_plays_in_chromium(coarse_fem, bent_q, tmp_path):
    """The page plays the animation by itself, and without play keeps frame 0. Every
    screenshot waits for a state of the page, never for time: all scene commands handled,
    then the animation at its end (played by itself), at 1 s (paused and sought: rest), or
    not started; and two frames drawn since."""
    require_chromium()
    fem = coarse_fem
    # Rest for frames 0-1, then up: at 0.5 frames/s the arm holds still for 2 s of
    # animation time and is up from 4 s on.
    q = np.array([fem.rest_q(), fem.rest_q(), bent_q])
    u = np.array([np.zeros(3), np.zeros(3), U_UP])
    tips = np.array([fem.tip(fem.to_nodes(qi)) for qi in q])
    pages = {
        play: A.animation_html(fem, q, u, targets_W=tips + [0, 0, 0.01], fps=0.5, play=play) for play in (True, False)
    }

    def shot(page):
        img = page.screenshot()[20:]  # below meshcat's GUI bar
        return _pixel_counts(img), _red_centroid(img)

    command = devtools_command()
    with DevToolsPage(command, tmp_path / "profile") as page:
        _load(page, pages[True], tmp_path / "play.html")
        assert page.evaluate("viewer.animator.duration") == 4
        assert page.evaluate("viewer.animator.playing || viewer.animator.time > 0")  # started by itself
        page.wait_for("viewer.animator.time >= viewer.animator.duration", 120, "the animation's end")
        late, tip_late = shot(page)
        page.evaluate("viewer.animator.pause(); viewer.animator.seek(1.0); true")
        early, tip_early = shot(page)
        _load(page, pages[False], tmp_path / "still.html")
        still, tip_still = shot(page)
        assert page.evaluate("!viewer.animator.playing && viewer.animator.time === 0")
    print(f"early {early} tip {tip_early}\nlate {late} tip {tip_late}\nstill {still} tip {tip_still}")
    for counts, tip in ((early, tip_early), (late, tip_late), (still, tip_still)):
        assert counts["foam"] > 5000 and counts["foam"] > 0.5 * counts["drawn"], counts  # the body
        assert counts["cyan"] > 30, counts  # cables at u = 0
        assert tip[2] > 20, tip  # the tip marker
    # At rest no cable is pulled; at the end the top cable shows u_max (magenta) and
    # the tip has risen on screen (the arm bends ~9 cm up: > 60 px here).
    assert early["magenta"] < 100 and still["magenta"] < 100, (early, still)
    assert late["magenta"] > 30, late
    assert tip_early[0] - tip_late[0] > 60, (tip_early, tip_late)
    # Without play the page keeps frame 0: the motion above is the animation's.
    assert abs(tip_still[0] - tip_early[0]) < 3 and abs(tip_still[1] - tip_early[1]) < 3, (tip_still, tip_early)
