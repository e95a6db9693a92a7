"""A NatNet server (OptiTrack Motive stand-in) on loopback UDP, for the real ``natnet`` client.

The command socket answers connect, model-definition and frame requests and registers
unicast clients; a streaming thread sends a frame every ``1/frame_rate_hz`` s, unicast to
each client or to the multicast group (loopback, TTL 0: nothing leaves the machine). Each
frame holds the tip marker (``tip_W_m(t_s)``, m in frame W, e.g. ``LiveBody.p_tip_W``) and
the base markers, mapped into the mocap frame by the scene's rigid transform, in the
scene's length unit, with optional noise; untracked markers follow Motive's conventions.
On a ``VirtualClock`` it sends one frame per frame a reader wants, advancing the clock by a
period each time. On the wall clock it keeps its own pace: ``frames_sent``, the longest gap
between two (``max_frame_gap_s``) and the frame times it skipped because its thread ran late
(``frames_skipped``: it never bursts to catch up). Faults: ``occlude_tip(True)``, ``freeze()`` (the server disappears),
``stop()``. Details: ``docs/design/rig.md``.
"""

from __future__ import annotations

import socket
import struct
import threading
import time
from collections.abc import Callable

import numpy as np

from lab.rig.emulators import natnet_packets as nn
from lab.rig.emulators.clock import VirtualClock
from lab.rig.emulators.mocap_scene import MocapScene


class NatNetServerEmulator:
    """Loopback NatNet server; ``command_port``/``data_port`` are the bound ports.

    Use as a context manager (or ``start()``/``stop()``); its threads always stop.

    Parameters
    ----------
    tip_W_m : callable
        ``tip_W_m(t_s)``: the tip marker's position, shape (3,), in m in W at server time
        ``t_s`` (s), e.g. ``LiveBody.p_tip_W``.
    scene : MocapScene
        The markers and the placement of W in the mocap frame.
    version : tuple of int
        NatNet protocol version, e.g. (3, 1).
    frame_rate_hz : float
        Frame rate (Hz) on the wall clock.
    multicast : bool
        Stream to ``multicast_address`` (True) or unicast to each client (False).
    multicast_address : str
        The multicast group (loopback, TTL 0).
    command_port, data_port : int
        UDP ports to bind; 0 picks free ones.
    noise_m : float
        Gaussian noise per axis on every marker (m).
    seed : int
        Seed of the noise.
    host : str
        The loopback address to bind.
    clock : VirtualClock, optional
        None streams on the wall clock at ``frame_rate_hz``; a ``VirtualClock`` sends a
        frame for each wish (``VirtualClock.want_frame``) and then advances the clock by
        one frame period.
    before_frame : callable, optional
        Called before each frame on a virtual clock (e.g. to let the body take the
        commands of the current time).
    """

    CLIENT_TIMEOUT_S = 10.0

    def __init__(
        self,
        tip_W_m: Callable[[float], np.ndarray],
        scene: MocapScene = MocapScene(),
        *,
        version=(3, 1),
        frame_rate_hz: float = 120.0,
        multicast: bool = False,
        multicast_address: str = "239.255.42.99",
        command_port: int = 0,
        data_port: int = 0,
        noise_m: float = 0.0,
        seed: int = 0,
        host: str = "127.0.0.1",
        clock: VirtualClock | None = None,
        before_frame: Callable[[], None] | None = None,
    ):
        self.tip_W_m, self.scene = tip_W_m, scene
        self.clock, self.before_frame = clock, before_frame
        self._clock = time.monotonic if clock is None else clock.now
        self.version = nn._check(version)
        self.frame_rate_hz = float(frame_rate_hz)
        self.multicast, self.multicast_address, self.host = multicast, multicast_address, host
        self.noise_m = float(noise_m)
        self._rng = np.random.default_rng(seed)
        self._cmd = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._cmd.bind((host, command_port))
        self._cmd.settimeout(0.05)
        self.command_port = self._cmd.getsockname()[1]
        self._data = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        if multicast:
            if data_port == 0:
                data_port = _free_udp_port(host)
            self._data.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(host))
            self._data.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
            self._data.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
            self._data.bind((host, 0))
            self.data_port = data_port
        else:
            self._data.bind((host, data_port))
            self.data_port = self._data.getsockname()[1]
        self._clients: dict[tuple, float] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._frozen = threading.Event()
        self._occluded = False
        self._threads: list[threading.Thread] = []
        self._t0 = self._clock()
        self.frames_sent = 0
        self.max_frame_gap_s = 0.0  # longest wall-clock time between two frames sent, s
        self.frames_skipped = 0  # frame times passed while the streaming thread was behind (wall clock)
        self._t_wall_last = 0.0

    # --- lifecycle and faults -------------------------------------------------------
    def start(self) -> NatNetServerEmulator:
        """Start the command and streaming threads.

        Returns
        -------
        NatNetServerEmulator
            ``self``, serving.
        """
        stream = self._stream if self.clock is None else self._stream_on_wish
        for target, name in ((self._serve_commands, "natnet-cmd"), (stream, "natnet-data")):
            t = threading.Thread(target=target, name=name, daemon=True)
            t.start()
            self._threads.append(t)
        return self

    def stop(self) -> None:
        """Stop the threads and close the sockets."""
        self._stop.set()
        for t in self._threads:
            t.join(timeout=5.0)
        self._cmd.close()
        self._data.close()

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
        return False

    def freeze(self) -> None:
        """The server disappears: no more frames, no more answers."""
        self._frozen.set()

    def occlude_tip(self, occluded: bool = True) -> None:
        """Hide (or show again) the tip marker, as Motive reports an untracked marker.

        Parameters
        ----------
        occluded : bool
            True hides the tip marker from the next frame on; False shows it.
        """
        self._occluded = bool(occluded)

    def now(self) -> float:
        """The server's time: wall clock or virtual, since construction.

        Returns
        -------
        float
            Seconds since construction.
        """
        return self._clock() - self._t0

    @property
    def clients(self) -> list[tuple]:
        """The registered unicast clients' (host, port) addresses."""
        with self._lock:
            return list(self._clients)

    # --- messages -------------------------------------------------------------------
    def server_info(self) -> bytes:
        """The answer to a connect request.

        Returns
        -------
        bytes
            A NatNet server-info packet (version, multicast settings, data port).
        """
        return nn.server_info(
            self.version, multicast=self.multicast, multicast_address=self.multicast_address, data_port=self.data_port
        )

    def model_def(self) -> bytes:
        """The answer to a model-definition request.

        Returns
        -------
        bytes
            A NatNet model-definition packet: the scene's marker sets and tip rigid body.
        """
        s = self.scene
        sets = [(s.marker_set, s.marker_names), ("all", s.marker_names)]
        bodies = []
        if s.tip_rigid_body is not None:
            offsets = [(0.01, 0.0, 0.0), (0.0, 0.01, 0.0), (0.0, 0.0, 0.01)]
            bodies.append((s.tip_rigid_body[0], s.tip_rigid_body[1], -1, (0.0, 0.0, 0.0), offsets))
        return nn.model_def(self.version, sets, bodies)

    def frame(self, frame_number: int, t_s: float) -> bytes:
        """One frame of data, with the tip where ``tip_W_m(t_s)`` puts it.

        Parameters
        ----------
        frame_number : int
            The frame's number.
        t_s : float
            Server time (s) of the frame.

        Returns
        -------
        bytes
            A NatNet frame-of-data packet: marker sets, labeled markers and the tip rigid
            body, in the mocap frame and the scene's unit (tip untracked while occluded).
        """
        s = self.scene
        p_W = np.vstack(
            [np.asarray(self.tip_W_m(t_s), dtype=float).reshape(1, 3), np.asarray(s.base_positions_W_m, dtype=float)]
        )
        p_M = s.to_mocap(p_W)
        if self.noise_m > 0:
            p_M = p_M + self._rng.normal(0.0, self.noise_m / s.length_unit_m, p_M.shape)
        pts = [tuple(map(float, p)) for p in p_M]
        hidden = self._occluded
        set_pts = ([(0.0, 0.0, 0.0)] if hidden else pts[:1]) + pts[1:]
        labeled = [
            nn.LabeledMarkerState((s.marker_set_model_id << 16) | (k + 1), p)
            for k, p in enumerate(pts)
            if not (hidden and k == 0)
        ]
        rbs = []
        if s.tip_rigid_body is not None:
            rbs.append(
                nn.RigidBodyState(s.tip_rigid_body[1], (0.0, 0.0, 0.0) if hidden else pts[0], tracking_valid=not hidden)
            )
        frame = nn.Frame(
            frame_number,
            t_s,
            marker_sets=[(s.marker_set, set_pts), ("all", set_pts)],
            rigid_bodies=rbs,
            labeled=labeled,
            stamp_ticks=int(t_s * 1e7),
        )
        return nn.frame_of_data(self.version, frame)

    # --- threads --------------------------------------------------------------------
    def _serve_commands(self) -> None:
        while not self._stop.is_set():
            try:
                data, addr = self._cmd.recvfrom(65536)
            except (TimeoutError, BlockingIOError):
                continue
            except OSError:
                if self._stop.is_set():
                    return
                continue  # e.g. ICMP unreachable from a client that went away
            if self._frozen.is_set() or len(data) < 4:
                continue
            message_id = struct.unpack_from("<H", data)[0]
            self._answer(message_id, addr)

    def _answer(self, message_id: int, addr) -> None:
        reply = None
        if message_id == nn.NAT_CONNECT:
            reply = self.server_info()
        elif message_id == nn.NAT_REQUEST_MODELDEF:
            reply = self.model_def()
        elif message_id == nn.NAT_REQUEST_FRAMEOFDATA:
            reply = self.frame(self.frames_sent, self.now())
        elif message_id == nn.NAT_REQUEST:
            reply = nn.message(nn.NAT_RESPONSE, struct.pack("<i", 0))
        elif message_id not in (nn.NAT_KEEPALIVE, nn.NAT_DISCONNECT):
            reply = nn.message(nn.NAT_UNRECOGNIZED_REQUEST, b"")
        if reply is not None:
            try:
                self._cmd.sendto(reply, addr)
            except OSError:
                return
        with self._lock:  # registered only after the server info went out: frames come after it
            if message_id == nn.NAT_CONNECT or (message_id == nn.NAT_KEEPALIVE and addr in self._clients):
                self._clients[addr] = time.monotonic()
            elif message_id == nn.NAT_DISCONNECT:
                self._clients.pop(addr, None)

    def _stream(self) -> None:
        period = 1.0 / self.frame_rate_hz
        next_t = time.monotonic()
        while not self._stop.wait(max(0.0, next_t - time.monotonic())):
            next_t += period
            late_s = time.monotonic() - next_t
            if late_s > period:  # fell behind: skip, do not burst, and count what was skipped
                self.frames_skipped += int(late_s // period)
                next_t = time.monotonic() + period
            if self._frozen.is_set():
                continue
            self._send_frame()

    def _stream_on_wish(self) -> None:
        period = 1.0 / self.frame_rate_hz
        while not self._stop.is_set():
            if not self.clock.take_wish(0.05) or self._frozen.is_set():
                continue
            if self.before_frame is not None:
                self.before_frame()
            self.clock.advance(period)
            self._send_frame()

    def _send_frame(self) -> None:
        t_wall = time.monotonic()
        if self.frames_sent:
            self.max_frame_gap_s = max(self.max_frame_gap_s, t_wall - self._t_wall_last)
        self._t_wall_last = t_wall
        packet = self.frame(self.frames_sent, self.now())
        self.frames_sent += 1
        if self.multicast:
            targets = [(self.multicast_address, self.data_port)]
        else:
            with self._lock:
                cutoff = time.monotonic() - self.CLIENT_TIMEOUT_S
                self._clients = {a: t for a, t in self._clients.items() if t > cutoff}
                targets = list(self._clients)
        for addr in targets:
            try:
                self._data.sendto(packet, addr)
            except OSError:
                with self._lock:
                    self._clients.pop(addr, None)


def multicast_loopback_works(group: str = "239.255.42.99", host: str = "127.0.0.1") -> bool:
    """Whether this machine delivers a multicast datagram sent on the loopback interface
    (TTL 0) back to a member socket: the condition for multicast NatNet on loopback.

    Parameters
    ----------
    group : str
        The multicast group to try.
    host : str
        The loopback interface's address.

    Returns
    -------
    bool
        True when the datagram came back within 1 s.
    """
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
        try:
            rx.bind((group, 0))
            rx.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, socket.inet_aton(group) + socket.inet_aton(host))
            rx.settimeout(1.0)
            tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(host))
            tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
            tx.sendto(b"probe", (group, rx.getsockname()[1]))
            return rx.recv(16) == b"probe"
        except OSError:
            return False


def _free_udp_port(host: str) -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]
