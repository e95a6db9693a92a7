"""A live meshcat viewer served by the notebook's own kernel, and an arm drawn in it.

:func:`live_viewer` starts, once per process, meshcat's ZMQ-to-websocket bridge in a
**daemon thread of the kernel** (its own asyncio loop), serving meshcat's page at
``http://127.0.0.1:PORT/static/`` on loopback only; Python talks to it over an in-process
ZMQ socket. No second process is started: the viewer lives exactly as long as the kernel,
and a kernel stopped, restarted or killed with ``kill -9`` leaves no server, thread or
port behind (tests/test_live_meshcat.py proves both). :mod:`lab.viz.live_arm` draws the
arm in it. A drawing lives under a top-level name (``vis["arm"]``); :meth:`LiveViewer.focus`
shows one of them at a time, since every view of the one viewer shows the same scene.

Whether a chapter uses it is decided by :func:`live_viewer_wanted`: a front end where the
user can type (JupyterLab, Notebook, VS Code send ``allow_stdin``; papermill and nbclient
do not), unless the environment variable ``LAB_LIVE_VIEWER`` is ``0`` (e.g. a remote
kernel whose loopback the browser cannot reach) or ``1`` (live in any kernel). Elsewhere
the chapters keep the static HTML snapshot. See docs/live-viewer.md.
"""

from __future__ import annotations

import os
import threading
import warnings

import numpy as np

from lab.errors import LabRuntimeError
from lab.viz.arm import _meshcat, set_view

__all__ = [
    "LIVE_VIEWER_ENV",
    "LiveViewer",
    "live_viewer",
    "live_viewer_wanted",
    "stop_live_viewer",
    "widgets_available",
    "front_end_available",
]

#: Environment variable: ``0`` never starts the live viewer, ``1`` starts it in any kernel.
LIVE_VIEWER_ENV = "LAB_LIVE_VIEWER"
#: Seconds a scene command may wait for the viewer thread before the viewer counts as dead.
REPLY_TIMEOUT_S = 10.0
#: The point of frame W (m) shown at the scene's origin, which meshcat 0.3.2 orbits about:
#: the middle of the 20 cm arms, so that the arm turns about itself, not its base.
VIEW_CENTRE_W = (0.10, 0.0, 0.0)
#: The camera (m), relative to VIEW_CENTRE_W: front left, a little above; the arm bent
#: either way by u_max fills a 400 px high view.
CAMERA_W = (0.03, -0.17, 0.05)


def widgets_available() -> bool:
    """Whether ipywidgets imports and an IPython kernel (a front end's) is running.

    Returns
    -------
    bool
        True if both hold.
    """
    try:
        import ipywidgets  # noqa: F401
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    return shell is not None and getattr(shell, "kernel", None) is not None


def front_end_available() -> bool:
    """True if widgets can be shown: ipywidgets imports, an IPython kernel runs, and the
    client lets the user type (``allow_stdin``). Papermill and nbclient execute with
    ``allow_stdin=False``, so a notebook they run gets the static figure instead."""
    if not widgets_available():
        return False
    from IPython import get_ipython

    return bool(getattr(get_ipython().kernel, "_allow_stdin", True))


def live_viewer_wanted() -> bool:
    """Whether to draw in the live viewer: ``LAB_LIVE_VIEWER=0`` no, ``=1`` in any IPython
    kernel, unset when :func:`front_end_available` (an interactive front end).

    Returns
    -------
    bool
        True to draw in the live viewer, False for the static snapshot.
    """
    setting = os.environ.get(LIVE_VIEWER_ENV, "").strip()
    if setting == "0":
        return False
    return widgets_available() if setting == "1" else front_end_available()


def _bridge_class():
    """meshcat's bridge, bound to 127.0.0.1 on a free port, quiet, loopback hosts only."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import tornado.web
        import tornado.websocket
        import umsgpack
        from meshcat.servers import zmqserver as Z

    def loopback_only(handler) -> None:  # no DNS-rebound page may read the scene
        port = handler.application.settings["port"]
        if handler.request.host not in (f"127.0.0.1:{port}", f"localhost:{port}"):
            raise tornado.web.HTTPError(403)

    class Static(Z.StaticFileHandlerNoCache):
        def prepare(self):
            loopback_only(self)

    class Socket(tornado.websocket.WebSocketHandler):  # meshcat's, without prints or images
        def initialize(self, bridge):
            self.bridge = bridge

        def prepare(self):
            loopback_only(self)

        def open(self):
            self.bridge.websocket_pool.add(self)
            self.bridge.send_scene(self)

        def on_message(self, message):
            pass  # image capture is not used; a reply would break the REQ/REP order

        def on_close(self):
            self.bridge.websocket_pool.discard(self)

    class Bridge(Z.ZMQWebSocketBridge):
        def __init__(self, zmq_url):  # not meshcat's: that listens on every interface
            import tornado.httpserver
            import tornado.ioloop
            import tornado.netutil

            self.host, self.websocket_pool, self.tree = "127.0.0.1", set(), Z.SceneTree()
            self.ioloop = tornado.ioloop.IOLoop.current()
            self.zmq_socket, self.zmq_stream, self.zmq_url = self.setup_zmq(zmq_url)
            self.sockets = tornado.netutil.bind_sockets(0, "127.0.0.1")
            self.fileserver_port = self.sockets[0].getsockname()[1]
            self.app = self.make_app()
            self.http = tornado.httpserver.HTTPServer(self.app)
            self.http.add_sockets(self.sockets)
            self.web_url = f"http://127.0.0.1:{self.fileserver_port}/static/"

        def make_app(self):
            root = {"path": Z.VIEWER_ROOT, "default_filename": Z.VIEWER_HTML}
            routes = [(r"/static/(.*)", Static, root), (r"/", Socket, {"bridge": self})]
            return tornado.web.Application(routes, log_function=lambda h: None, port=self.fileserver_port)

        def handle_zmq(self, frames):
            if frames[0] == b"set_property" and len(frames) == 3:  # keep the latest value per key only
                node = Z.find_node(self.tree, [p for p in frames[1].decode().split("/") if p])
                key = umsgpack.unpackb(frames[2])["property"]
                node.properties = [p for p in node.properties if umsgpack.unpackb(p)["property"] != key]
            super().handle_zmq(frames)

    return Bridge


class LiveViewer:
    """A meshcat server in a daemon thread of this process; ``vis`` is its
    ``meshcat.Visualizer``, ``url`` its page (``http://127.0.0.1:PORT/static/``)."""

    def __init__(self, timeout_s: float = REPLY_TIMEOUT_S):
        import asyncio

        import zmq

        self._zmq, self._lock, self._shown = zmq, threading.Lock(), None
        self._prefixes: set[str] = set()
        Bridge, ready, self._error = _bridge_class(), threading.Event(), None
        zmq_url = f"inproc://lab-live-viewer-{id(self)}"

        def serve():
            self.loop = asyncio.new_event_loop()
            asyncio.set_event_loop(self.loop)
            try:
                self.bridge = Bridge(zmq_url)
            except Exception as err:  # noqa: BLE001 - reported to the caller's thread
                self._error = err
            ready.set()
            if self._error is None:
                self.loop.run_forever()
                self.bridge.http.stop()
                self.bridge.zmq_stream.close(linger=0)
                for ws in list(self.bridge.websocket_pool):
                    ws.close()
            self.loop.close()

        self.thread = threading.Thread(target=serve, name="lab-live-viewer", daemon=True)
        self.thread.start()
        if not ready.wait(timeout_s) or self._error is not None:
            raise LabRuntimeError(f"the live meshcat viewer did not start: {self._error or 'no answer'}")
        self.port, self.url = self.bridge.fileserver_port, self.bridge.web_url
        self.web_url = self.url  # what meshcat.Visualizer.url() reads
        self.socket = Bridge.context.socket(zmq.REQ)  # inproc needs the bridge's context
        self.socket.setsockopt(zmq.RCVTIMEO, int(1000 * timeout_s))
        self.socket.setsockopt(zmq.SNDTIMEO, int(1000 * timeout_s))
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.connect(zmq_url)
        self.vis = _meshcat().Visualizer(window=self)
        set_view(self.vis, camera_W=CAMERA_W)
        self.vis.set_transform(_meshcat().transformations.translation_matrix(-np.asarray(VIEW_CENTRE_W)))

    @property
    def alive(self) -> bool:
        return self.thread.is_alive() and not self.socket.closed

    # meshcat.Visualizer's window interface: send() and get_scene()
    def _request(self, frames) -> bytes:
        with self._lock:
            try:
                self.socket.send_multipart(frames)
                return self.socket.recv()
            except self._zmq.ZMQError as err:
                self.socket.close(linger=0)
                raise LabRuntimeError(f"the live meshcat viewer at {self.url} stopped answering: {err}") from err

    def send(self, command) -> None:
        import umsgpack

        data = command.lower()
        self._request([data["type"].encode(), data["path"].encode(), umsgpack.packb(data)])

    def get_scene(self) -> str:
        """The scene as one self-contained HTML page (what ``vis.static_html()`` returns)."""
        return self._request([b"get_scene"]).decode()

    def focus(self, prefix: str) -> None:
        """Show only the drawing under ``vis[prefix]`` (a top-level name such as "arm"):
        the other drawings made through this viewer are hidden, not deleted."""
        self._prefixes.add(prefix)
        if self._shown != prefix:
            for name in sorted(self._prefixes):
                self.vis[name].set_property("visible", name == prefix)
            self._shown = prefix

    def iframe_html(self, height_px: int = 400) -> str:
        """An ``<iframe>`` of the viewer page for a notebook output or an ipywidgets.HTML."""
        return (
            f'<div style="height: {int(height_px)}px; width: 100%; overflow: hidden; resize: vertical">'
            f'<iframe src="{self.url}" title="live meshcat viewer" '
            'style="width: 100%; height: 100%; border: none"></iframe></div>'
        )

    def show(self, height_px: int = 400):
        """The viewer as a notebook output (``IPython.display.HTML``)."""
        from IPython.display import HTML

        return HTML(self.iframe_html(height_px))

    def stop(self) -> None:
        """Stop the server thread and close its port (a kernel's exit does this too)."""
        if self.thread.is_alive():
            self.loop.call_soon_threadsafe(self.loop.stop)
            self.thread.join(REPLY_TIMEOUT_S)
        self.socket.close(linger=0)


_VIEWER: LiveViewer | None = None
_VIEWER_LOCK = threading.Lock()


def live_viewer() -> LiveViewer:
    """This process's live viewer, started on the first call (reused by every cell).

    Returns
    -------
    LiveViewer
        The running viewer (a new one if the last one died).
    """
    global _VIEWER
    with _VIEWER_LOCK:
        if _VIEWER is None or not _VIEWER.alive:
            _VIEWER = LiveViewer()
        return _VIEWER


def stop_live_viewer() -> None:
    """Stop this process's live viewer, if one runs."""
    global _VIEWER
    with _VIEWER_LOCK:
        if _VIEWER is not None:
            _VIEWER.stop()
            _VIEWER = None
