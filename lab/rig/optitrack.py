"""OptiTrack motion capture through the real ``natnet`` client: the tip marker in frame W.

``OptiTrackStream`` connects to Motive's NatNet server (unicast or multicast), queues the
frames the client's threads receive and hands them out as ``MocapFrame(t_s, p_tip_W)``.
Markers are found by ``MarkerRef`` (a marker-set name, a labeled-marker ID or a rigid
body); one Motive does not see gives an all-NaN tip. Frame W comes from the base markers,
fitted by a rigid transform (Kabsch) after connecting (a fit RMS above
``max_base_fit_rms_m`` is refused); ``t_s`` is the host clock when the frame arrived.
``MocapError`` when no frame arrives for ``frame_timeout_s`` (wall clock) or the tip stays
occluded longer than ``max_occlusion_s`` (on ``clock``). Details: ``docs/design/rig.md``.
"""

from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass

import numpy as np

from lab.rig.base import MocapError, MocapFrame


@dataclass(frozen=True)
class MarkerRef:
    """One marker: ``marker`` in ``marker_set`` | ``labeled_marker_id`` | ``rigid_body``
    (name) | ``rigid_body_id`` -- exactly one of them."""

    marker: str | None = None
    marker_set: str | None = None
    labeled_marker_id: int | None = None
    rigid_body: str | None = None
    rigid_body_id: int | None = None

    def __str__(self) -> str:
        if self.marker is not None:
            return f"marker {self.marker!r} of marker set {self.marker_set!r}"
        if self.labeled_marker_id is not None:
            return f"labeled marker {self.labeled_marker_id}"
        if self.rigid_body is not None:
            return f"rigid body {self.rigid_body!r}"
        return f"rigid body {self.rigid_body_id}"


@dataclass(frozen=True)
class NatNetConfig:
    """Connection and marker settings (SI units; ``length_unit_m`` is Motive's unit in m)."""

    server_address: str
    local_address: str
    multicast: bool
    tip: MarkerRef
    base_markers: tuple
    base_positions_W_m: np.ndarray  # (k, 3) m, one row per base marker
    multicast_address: str = "239.255.42.99"
    command_port: int = 1510
    data_port: int = 1511
    length_unit_m: float = 1.0
    connect_timeout_s: float = 5.0
    frame_timeout_s: float = 0.5
    max_occlusion_s: float = 2.0
    calibration_frames: int = 600
    max_base_fit_rms_m: float = 0.003
    queue_frames: int = 1200


def fit_rigid_transform(p_src: np.ndarray, p_dst: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Rotation R (3, 3) and translation t (3,) minimising |R p_src + t - p_dst| (Kabsch,
    det R = +1), and the RMS residual (same unit). ``p_src``, ``p_dst``: (k >= 3, 3)."""
    p_src, p_dst = np.asarray(p_src, float), np.asarray(p_dst, float)
    c_src, c_dst = p_src.mean(axis=0), p_dst.mean(axis=0)
    H = (p_src - c_src).T @ (p_dst - c_dst)
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    R = Vt.T @ D @ U.T
    t = c_dst - R @ c_src
    rms = float(np.sqrt(np.mean(np.sum((p_src @ R.T + t - p_dst) ** 2, axis=1))))
    return R, t, rms


def _pick(frame, ref: MarkerRef, index: int | None) -> np.ndarray:
    """Position (3,) of ``ref`` in ``frame`` in Motive's unit; NaN when not seen."""
    nan = np.full(3, np.nan)
    if ref.marker is not None:
        for ms in frame.marker_sets or ():
            if ms.model_name == ref.marker_set and index < len(ms.marker_pos_list):
                p = np.asarray(ms.marker_pos_list[index], float)
                return p if np.all(np.isfinite(p)) and np.any(p != 0.0) else nan
        return nan
    if ref.labeled_marker_id is not None:
        for lm in frame.labeled_markers or ():
            if lm.id_num == ref.labeled_marker_id:
                return nan if (lm.param or 0) & 0x01 else np.asarray(lm.pos, float)
        return nan
    for rb in frame.rigid_bodies or ():
        if rb.id_num == index:
            return nan if rb.tracking_valid is False else np.asarray(rb.pos, float)
    return nan


class OptiTrackStream:
    """Connected, calibrated NatNet stream of tip positions in W; ``clock`` (s) stamps frames.

    ``frame_wanted``: optional, called whenever a reader is about to wait for a frame with
    none queued (an emulated server on a ``VirtualClock`` sends one frame per call).
    Raises ``MocapError`` (client shut down) when connecting, resolving names or
    calibrating fails.
    """

    def __init__(self, config: NatNetConfig, clock=time.monotonic, frame_wanted=None):
        import natnet  # the real client package (pure Python, NatNet 2-4)

        self.config, self._clock, self._frame_wanted = config, clock, frame_wanted
        self._where = (
            f"NatNet server {config.server_address}:{config.command_port} "
            f"({'multicast' if config.multicast else 'unicast'})"
        )
        self._cond = threading.Condition()
        self._queue: collections.deque = collections.deque(maxlen=config.queue_frames)
        self._pickers = None
        self._descriptions = None
        self._handler_error: BaseException | None = None
        self._closed = False
        self.frames_received = self.frames_dropped = 0
        self._t_first = self._t_latest = None
        self._client = natnet.NatNetClient(
            server_ip_address=config.server_address,
            local_ip_address=config.local_address,
            multicast_address=config.multicast_address,
            command_port=config.command_port,
            data_port=config.data_port,
            use_multicast=config.multicast,
        )
        self._client.on_data_frame_received_event.handlers.append(self._on_frame)
        self._client.on_data_description_received_event.handlers.append(self._on_descriptions)
        try:
            try:
                self._client.connect(timeout=config.connect_timeout_s)
            except (TimeoutError, OSError, natnet.NatNetError) as err:
                raise MocapError(
                    f"cannot connect to {self._where} within {config.connect_timeout_s} s: "
                    f"{type(err).__name__} {err} (is Motive streaming, are the addresses, ports "
                    "and transmission type right?)"
                ) from None
            self.server_info = self._client.server_info
            self._client.run_async()
            self._pickers = self._resolve()
            self.R_WM, self.t_WM_m, self.base_fit_rms_m = self._calibrate()
            self._t_last_valid = self._clock()
        except BaseException:
            self.close()
            raise

    # --- background thread ----------------------------------------------------------
    def _on_descriptions(self, descriptions) -> None:
        with self._cond:
            self._descriptions = descriptions
            self._cond.notify_all()

    def _on_frame(self, frame) -> None:
        """Runs on the natnet client's thread: never raise there (it would end the thread)."""
        try:
            if self._pickers is None:
                return
            t_s = self._clock()
            points = [_pick(frame, ref, index) * self.config.length_unit_m for ref, index in self._pickers]
            with self._cond:
                if len(self._queue) == self._queue.maxlen:
                    self.frames_dropped += 1
                self._queue.append((t_s, points[0], np.array(points[1:])))
                self.frames_received += 1
                self._t_first = t_s if self._t_first is None else self._t_first
                self._t_latest = t_s
                self._cond.notify_all()
        except BaseException as err:  # noqa: BLE001 - reported by next_frame
            with self._cond:
                self._handler_error = err
                self._cond.notify_all()

    # --- set-up ---------------------------------------------------------------------
    def _resolve(self) -> list:
        refs = [self.config.tip, *self.config.base_markers]
        if any(r.marker is not None or r.rigid_body is not None for r in refs):
            d = self._await_descriptions()
        out = []
        for ref in refs:
            index = ref.rigid_body_id
            if ref.marker is not None:
                sets = {ms.name: ms.marker_names for ms in d.marker_sets}
                if ref.marker_set not in sets:
                    raise MocapError(f"{self._where} has no marker set {ref.marker_set!r}; it has {sorted(sets)}")
                if ref.marker not in sets[ref.marker_set]:
                    raise MocapError(
                        f"marker set {ref.marker_set!r} has no marker {ref.marker!r}; "
                        f"it has {list(sets[ref.marker_set])}"
                    )
                index = list(sets[ref.marker_set]).index(ref.marker)
            elif ref.rigid_body is not None:
                bodies = {rb.name: rb.id_num for rb in d.rigid_bodies}
                if ref.rigid_body not in bodies:
                    raise MocapError(f"{self._where} has no rigid body {ref.rigid_body!r}; it has {sorted(bodies)}")
                index = bodies[ref.rigid_body]
            out.append((ref, index))
        return out

    def _await_descriptions(self):
        deadline = time.monotonic() + self.config.connect_timeout_s
        with self._cond:
            while self._descriptions is None:
                self._client.request_modeldef()  # UDP: ask again until answered
                self._cond.wait(timeout=min(0.5, max(0.0, deadline - time.monotonic())))
                if self._descriptions is None and time.monotonic() >= deadline:
                    raise MocapError(
                        f"{self._where} sent no model definitions within {self.config.connect_timeout_s} s"
                    )
            return self._descriptions

    def _calibrate(self) -> tuple[np.ndarray, np.ndarray, float]:
        c = self.config
        seen, tries = [], 0
        while len(seen) < c.calibration_frames:
            _t, _tip, base = self._pop()
            tries += 1
            if np.all(np.isfinite(base)):
                seen.append(base)
            elif tries > 10 * c.calibration_frames:
                missing = [str(r) for r, ok in zip(c.base_markers, np.all(np.isfinite(base), axis=1)) if not ok]
                raise MocapError(f"base markers not visible, cannot establish frame W: {missing}")
        p_M = np.mean(seen, axis=0)
        R, t, rms = fit_rigid_transform(p_M, c.base_positions_W_m)
        if rms > c.max_base_fit_rms_m:
            raise MocapError(
                f"base markers do not match their configured positions in W: fit RMS "
                f"{rms * 1e3:.1f} mm > {c.max_base_fit_rms_m * 1e3:.1f} mm (check marker names/IDs, "
                "base_markers positions and length_unit)"
            )
        return R, t, rms

    # --- frames ---------------------------------------------------------------------
    def _pop(self):
        timeout = self.config.frame_timeout_s
        with self._cond:
            if not self._queue and self._frame_wanted is not None and not self._closed:
                self._frame_wanted()
            if not self._cond.wait_for(lambda: self._queue or self._handler_error or self._closed, timeout):
                raise MocapError(
                    f"no motion-capture frame from {self._where} for {timeout} s (server gone or streaming stopped)"
                )
            if self._handler_error is not None:
                raise MocapError(f"could not read a NatNet frame: {self._handler_error!r}")
            if self._closed:
                raise MocapError("motion-capture stream is closed")
            return self._queue.popleft()

    def next_frame(self) -> MocapFrame:
        """The oldest unread frame (blocks up to ``frame_timeout_s``): tip (3,) m in W, NaN
        when not seen. Raises MocapError after ``max_occlusion_s`` without a tip."""
        t_s, tip_M, _base = self._pop()
        if np.all(np.isfinite(tip_M)):
            self._t_last_valid = t_s
            return MocapFrame(t_s, self.R_WM @ tip_M + self.t_WM_m)
        if t_s - self._t_last_valid > self.config.max_occlusion_s:
            raise MocapError(
                f"tip {self.config.tip} occluded for {t_s - self._t_last_valid:.2f} s "
                f"(limit {self.config.max_occlusion_s} s)"
            )
        return MocapFrame(t_s, np.full(3, np.nan))

    @property
    def measured_rate_hz(self) -> float:
        """Mean rate of received frames since connecting (NaN before two frames)."""
        with self._cond:
            if self.frames_received < 2 or self._t_latest == self._t_first:
                return float("nan")
            return (self.frames_received - 1) / (self._t_latest - self._t_first)

    def close(self) -> None:
        """Stop the client's threads and close its sockets (idempotent)."""
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self._cond.notify_all()
        self._client.shutdown()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
