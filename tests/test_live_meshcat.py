"""The live meshcat viewer a kernel serves (lab.viz.live), the widgets that move the arm in
it, and the two widget fixes: equal slider tracks (chapter 01) and the picker's drop-down
leaving a trajectory point once a slider moves (chapter 04).

Without a browser, a websocket client stands in for the page: it receives what the viewer
sends, decoded with msgpack as meshcat's JavaScript does. The server is a thread of the
process that starts it: a process killed with ``kill -9``, or ending normally, leaves no
port, thread or child behind. With Chromium, chapter 01 runs in a kernel that the real
JupyterLab server started (test_jupyterlab's fixture), a slider is moved in that kernel and
the arm moves on the viewer's page; every wait is for a state of the page or the kernel.
"""

import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest
import umsgpack
from helpers import DevToolsPage, subprocess_env, wait_until
from test_animation import _red_centroid
from test_jupyterlab import CHAPTER, FLAGS, ROOT, _api, _execute, _first_cells, server  # noqa: F401
from test_viz import CHROMIUM, _pixel_counts, require_chromium

from lab.control import trajectories
from lab.fem import solve_static
from lab.learn import load_model
from lab.viz import IKPicker, sliders
from lab.viz import ik_picker as picker_module
from lab.viz import live as L
from lab.viz.live_arm import LiveArm, show_animation, show_arm

U_UP = np.array([3.0, 0.0, 0.0])  # top cable at u_max: the tip rises about 9 cm


@pytest.fixture
def viewer():
    yield L.live_viewer()
    L.stop_live_viewer()


class Page:
    """A websocket client in place of the viewer page."""

    def __init__(self, viewer):
        import websocket

        self.ws = websocket.create_connection(f"ws://127.0.0.1:{viewer.port}/", timeout=10)

    def read_until(self, predicate, what: str) -> list:
        """Receive until a message satisfies ``predicate``: the messages received, decoded."""
        import websocket

        got = []
        while not (got and predicate(got[-1])):
            try:
                got.append(umsgpack.unpackb(self.ws.recv()))
            except websocket.WebSocketTimeoutException:
                raise AssertionError(f"the viewer sent no {what} within 10 s ({len(got)} messages)") from None
        return got

    def close(self):
        self.ws.close()


def _tip_of(message, path="/meshcat/arm/tip"):
    return np.array(message["matrix"]).reshape(4, 4).T[:3, 3] if message["path"] == path else None


def _is(path, kind="set_transform"):
    return lambda m: m["type"] == kind and m["path"] == path


def test_viewer_is_a_loopback_thread_that_streams_the_arm(viewer, coarse_fem):
    assert L.live_viewer() is viewer  # one per process, reused by every cell
    assert viewer.thread.daemon and viewer.thread.name == "lab-live-viewer"
    assert viewer.url == f"http://127.0.0.1:{viewer.port}/static/"
    assert [s.getsockname()[0] for s in viewer.bridge.sockets] == ["127.0.0.1"]  # not every interface
    with urllib.request.urlopen(viewer.url, timeout=10) as r:
        assert "MeshCat.Viewer" in r.read().decode()
    with pytest.raises(urllib.error.HTTPError, match="403"):  # a DNS-rebound name is refused
        urllib.request.urlopen(urllib.request.Request(viewer.url, headers={"Host": "example.com"}), timeout=10)
    arm = LiveArm(viewer.vis, coarse_fem)
    first = Page(viewer)  # a page open while the arm moves gets the moves
    first.read_until(_is("/meshcat/arm/tip"), "the scene")
    arm.update(solve_static(coarse_fem, U_UP / 2).q, U_UP / 2)
    first.read_until(_is("/meshcat/arm/tip"), "the first move")
    q = solve_static(coarse_fem, U_UP).q
    pieces = arm.update(q, U_UP)
    moved = first.read_until(_is("/meshcat/arm/tip"), "the second move")
    np.testing.assert_allclose(_tip_of(moved[-1]), coarse_fem.tip(coarse_fem.to_nodes(q)), atol=1e-12)
    assert {m["type"] for m in moved} == {"set_transform", "set_property"}  # no object sent again
    n_pieces = 20 + 2 + sum(len(c.via_points_m) for c in coarse_fem.robot.cables) + 1
    assert sum(m["type"] == "set_transform" for m in moved) == n_pieces
    # A page opened later gets the whole current scene, one colour per piece (the latest).
    late = Page(viewer)
    scene = late.read_until(_is("/meshcat/arm/tip"), "the scene")
    top = f"/meshcat/arm/cables/{coarse_fem.robot.cables[0].name}/00"
    colors = [m["value"] for m in scene if m["type"] == "set_property" and m["path"] == top]
    assert len(colors) == 1 and colors[0][0] > colors[0][1], colors  # magenta-ish: u_max
    np.testing.assert_allclose(_tip_of(scene[-1]), pieces.tip_W, atol=1e-12)
    first.close()
    late.close()
    assert "MeshCat.Viewer" in viewer.vis.static_html()  # the snapshot still works


def test_explorer_sliders_move_the_live_arm(viewer, coarse_fem, monkeypatch):
    monkeypatch.setattr(sliders, "widgets_available", lambda: True)
    explorer = sliders.ArmExplorer(coarse_fem, levels=1)
    box = explorer.widget(live=True)
    assert explorer.fig is None and viewer.url in box.children[-1].value  # no matplotlib: the viewer
    page = Page(viewer)
    page.read_until(_is("/meshcat/arm/tip"), "the scene")
    explorer.sliders[0].value = 3.0  # what letting go of the first slider does
    moved = page.read_until(_is("/meshcat/arm/tip"), "the move")
    np.testing.assert_allclose(_tip_of(moved[-1]), explorer.last["p_tip_W"], atol=1e-12)
    assert explorer.last["p_tip_W"][2] > 0.05 and "tip at" in box.children[3].value
    explorer.sliders[1].value = explorer.sliders[2].value = 3.0  # 9 rad in total: unsafe, not applied
    assert not explorer.last["safe"] and "unsafe" in box.children[3].value
    page.close()


def test_show_arm_and_show_animation_live_or_static(viewer, coarse_fem, capsys):
    q = solve_static(coarse_fem, U_UP).q
    static = show_arm(coarse_fem, q, U_UP, live=False)  # papermill's: the scene in the page
    assert "<iframe srcdoc=" in static.data and "static snapshot" in capsys.readouterr().out
    assert static.png.startswith(b"\x89PNG")  # its still, for a page that runs no scene
    live = show_arm(coarse_fem, q, U_UP, live=True)
    assert f'<iframe src="{viewer.url}"' in live.data and viewer.url in capsys.readouterr().out
    view = viewer.bridge.tree["meshcat"]["view"]
    tip_W = np.array(umsgpack.unpackb(view["tip"].transform)["matrix"])[12:15]  # column-major: the translation
    np.testing.assert_allclose(tip_W, coarse_fem.tip(coarse_fem.to_nodes(q)), atol=1e-12)
    page = show_animation("<p>the page</p>", coarse_fem, q[None], live=False)
    assert page.data.count("<p>the page</p>") == 1 and page.png.startswith(b"\x89PNG")
    frames = np.array([coarse_fem.rest_q(), q])
    shown = show_animation("unused", coarse_fem, frames, np.array([0 * U_UP, U_UP]), live=True, n_segments=4)
    assert viewer.url in shown.data and viewer.bridge.tree.animation is not None  # played by the viewer
    hidden = [umsgpack.unpackb(p) for p in view.properties]
    assert [(p["property"], p["value"]) for p in hidden] == [("visible", False)]  # one drawing shown at a time
    assert set(viewer.bridge.tree["meshcat"]["anim"]["body"]) == {"00", "01", "02", "03", "base", "end"}


@pytest.fixture(scope="module")
def picker(three_cable, coarse_fem):
    model = load_model(ROOT / "data" / "model_sim_three_cable.npz")
    return IKPicker(model, three_cable, coarse_fem, targets_W=trajectories.builtin("square", 12))


def test_picker_moves_the_live_arm_and_its_target(viewer, picker, monkeypatch):
    monkeypatch.setattr(picker_module, "front_end_available", lambda: True)
    box = picker.widget(live=True)
    page = Page(viewer)
    page.read_until(_is("/meshcat/picker/path", "set_object"), "the scene")  # its last piece
    picker.points.value = 5
    moved = page.read_until(_is("/meshcat/picker/path", "set_object"), "the move")
    target = next(_tip_of(m, "/meshcat/picker/target") for m in moved if _is("/meshcat/picker/target")(m))
    np.testing.assert_allclose(target, picker.targets_W[5], atol=1e-6)
    tips = [_tip_of(m, "/meshcat/picker/arm/tip") for m in moved if _is("/meshcat/picker/arm/tip")(m)]
    np.testing.assert_allclose(tips[-1], picker.last["p_tip_W"], atol=1e-12)
    assert "target (" in box.children[4].value
    page.close()


def test_picker_drop_down_leaves_the_trajectory_point_when_a_slider_moves(picker, monkeypatch):
    monkeypatch.setattr(picker_module, "front_end_available", lambda: True)
    picker.widget(live=False)
    x, y, z = picker.sliders
    picker.points.value = 3
    np.testing.assert_allclose(picker.last["p_target_W"], picker.targets_W[3], atol=1e-9)
    y.value = y.value + 0.5  # a slider move: no longer trajectory point 3
    assert picker.points.value == -1 and picker.points.label == picker_module.CUSTOM_TARGET
    assert picker.last["p_target_W"][1] == pytest.approx(picker.targets_W[3][1] + 0.005)
    picker.points.value = 3  # and back: the point is solved again
    np.testing.assert_allclose(picker.last["p_target_W"], picker.targets_W[3], atol=1e-9)
    picker.fig = None


def test_slider_tracks_have_equal_widths(coarse_fem, picker, monkeypatch):
    """Each description gets the same fixed width, and each slider the same total width, so
    the tracks line up ("initial" gave widths that followed the labels: 147/108/98 px)."""
    monkeypatch.setattr(sliders, "widgets_available", lambda: True)
    monkeypatch.setattr(picker_module, "front_end_available", lambda: True)
    explorer = sliders.ArmExplorer(coarse_fem, levels=1)
    explorer.widget(live=False)
    picker.widget(live=False)
    picker.fig = None
    for group in (explorer.sliders, picker.sliders):
        widths = {(s.style.description_width, s.layout.width) for s in group}
        assert len(widths) == 1, widths
        description, total = widths.pop()
        assert description.endswith(("em", "px")) and total.endswith(("em", "px")), (description, total)
    assert len({s.description for s in explorer.sliders}) == 3  # different labels, one width


def test_live_viewer_only_where_a_front_end_can_show_it(coarse_fem, monkeypatch):
    monkeypatch.delenv(L.LIVE_VIEWER_ENV, raising=False)
    assert not L.live_viewer_wanted()  # plain Python
    # papermill's kernel: widgets, but no allow_stdin: the sliders draw matplotlib, no server starts
    monkeypatch.setattr(sliders, "widgets_available", lambda: True)
    monkeypatch.setattr(L, "widgets_available", lambda: True)
    monkeypatch.setattr(L, "front_end_available", lambda: False)
    explorer = sliders.ArmExplorer(coarse_fem, levels=1)
    assert explorer.widget() is not None and explorer.scene is None and explorer.fig is not None
    assert L._VIEWER is None and "lab-live-viewer" not in {t.name for t in threading.enumerate()}
    monkeypatch.setattr(L, "front_end_available", lambda: True)
    assert L.live_viewer_wanted()
    monkeypatch.setenv(L.LIVE_VIEWER_ENV, "0")  # a remote kernel: the browser cannot reach it
    assert not L.live_viewer_wanted()
    monkeypatch.setenv(L.LIVE_VIEWER_ENV, "1")
    monkeypatch.setattr(L, "front_end_available", lambda: False)
    assert L.live_viewer_wanted()


def _refused(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) != 0


def _children(pid: int) -> set:
    found = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found |= {int(c) for c in (task / "children").read_text().split()}
        except OSError:
            pass
    return found


STARTER = textwrap.dedent(
    """
    import sys, threading
    from lab.viz.live import live_viewer
    v = live_viewer()
    print(v.port, [t.name for t in threading.enumerate()], flush=True)
    if sys.argv[1] == "wait":
        sys.stdin.read()
    """
)


@pytest.mark.parametrize("end", ["kill -9", "exit"])
def test_no_server_outlives_its_process(end):
    proc = subprocess.Popen(
        [sys.executable, "-c", STARTER, "wait" if end == "kill -9" else "exit"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=subprocess_env(),
    )
    port, threads = proc.stdout.readline().split(" ", 1)
    port = int(port)
    assert "lab-live-viewer" in threads and not _children(proc.pid)  # a thread, no child process
    if end == "kill -9":
        assert not _refused(port)
        os.kill(proc.pid, signal.SIGKILL)
    t0 = time.monotonic()
    proc.wait(timeout=60)
    assert time.monotonic() - t0 < 30  # a normal exit does not hang on the server's sockets
    assert proc.returncode == (-signal.SIGKILL if end == "kill -9" else 0)
    assert _refused(port)
    proc.stdout.close()
    proc.stdin.close()


# ------------------------------------------------------------------ JupyterLab + Chromium
def _chapter_cells(*markers) -> str:
    """Chapter 01's code cells that contain each marker, in order, joined."""
    nb = json.loads((ROOT / "notebooks" / CHAPTER).read_text())
    code = ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]
    return "\n".join(next(c for c in code if m in c) for m in markers)


_TIP_Z = 'viewer.scene_tree.find(["meshcat", "arm", "tip"]).object.position.z'


@pytest.mark.slow
@pytest.mark.browser
def test_slider_moves_the_arm_in_the_live_viewer_of_a_jupyterlab_kernel(server, tmp_path):  # noqa: F811
    """Chapter 01 in a kernel the real JupyterLab started, executed as JupyterLab does
    (``allow_stdin``): its explorer cell opens the live viewer; Chromium loads the viewer page;
    a slider set in the kernel moves the arm on the page; the kernel stopped, nothing stays."""
    require_chromium()
    name = json.loads((ROOT / "notebooks" / CHAPTER).read_text())["metadata"]["kernelspec"]["name"]
    kernel = _api(server, "/api/kernels", "POST", {"name": name, "path": CHAPTER})
    try:

        def run(code):
            return _execute(server, kernel["id"], code, allow_stdin=True)[1]

        run(_first_cells(tmp_path / "figures").replace("quick = False", "quick = True", 1))
        run(_chapter_cells("robot = load_robot(robot_name)", "fem = ArmFEM(", "commands = {", "ArmExplorer(fem)"))
        out = run(
            "import threading, lab.viz.live as L\n"
            "print('LIVE', L.live_viewer().url, os.getpid(), explorer.scene is not None, explorer.fig is None,"
            " explorer.last['p_tip_W'][2], [s.value for s in explorer.sliders] == list(explorer.last['u_motor']),"
            " [t.name for t in threading.enumerate()])"
        )
        assert "LIVE " in out, out
        url, pid, live, no_png, z0, agree, threads = out.split("LIVE ", 1)[1].split(" ", 6)
        assert live == no_png == "True" and "lab-live-viewer" in threads, out  # the live path, not matplotlib
        assert agree == "True", out  # the sliders read the command of the pose first shown
        pid, port = int(pid), int(url.split(":")[2].split("/")[0])
        command = [str(CHROMIUM), *FLAGS]
        with DevToolsPage(command, tmp_path / "profile") as page:
            page.navigate(url)
            page.wait_for(
                f"typeof viewer !== 'undefined' && Math.abs({_TIP_Z} - {z0}) < 1e-6", 60, "the pose the sliders show"
            )
            z_rest = float(
                run("for s in explorer.sliders:\n    s.value = 0.0\nprint(explorer.last['p_tip_W'][2])").split()[-1]
            )
            page.wait_for(f"Math.abs({_TIP_Z} - {z_rest}) < 1e-6", 60, "the arm at rest")
            before = page.screenshot()[20:]
            z1 = float(run("explorer.sliders[0].value = 3.0\nprint(explorer.last['p_tip_W'][2])").split()[-1])
            page.wait_for(f"Math.abs({_TIP_Z} - {z1}) < 1e-6", 60, "the arm at the new command")
            after = page.screenshot()[20:]
        assert not {p for p in _children(pid) if "meshcat" in Path(f"/proc/{p}/cmdline").read_text()}
    finally:
        _api(server, f"/api/kernels/{kernel['id']}", "DELETE")
    (r0, c0, n0), (r1, c1, n1) = _red_centroid(before), _red_centroid(after)
    counts = _pixel_counts(before), _pixel_counts(after)
    print(f"tip z {z_rest} -> {z1} m; red centroid ({r0:.0f}, {c0:.0f}) -> ({r1:.0f}, {c1:.0f}); {counts}")
    assert n0 > 20 and n1 > 20 and counts[0]["foam"] > 3000, counts  # the tip marker and the body
    assert r0 - r1 > 100, (r0, r1)  # the tip rose on screen (about 9 cm: about 200 px)
    assert counts[0]["magenta"] < 100 < counts[1]["magenta"], counts  # the top cable now at u_max
    wait_until(lambda: not Path(f"/proc/{pid}").exists(), 60, "the kernel process to end")
    assert _refused(port)  # its viewer went with it
