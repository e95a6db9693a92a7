"""Measuring one sample with the protocol of Section III: reset, command, wait until settled, record.

For each motor command ``u`` (rad) the protocol **erases hysteresis** (``reset``: every
cable contracted to ``reset_u_rad``, released to 0, then ``u``), **waits until settled**
(``wait``: once the motors arrived, the current reading -- the mean of the valid frames
over ``reading_period_s`` -- is within ``settle_tol_m`` of the mean of the previous
``n_previous`` readings; not settled within ``settle_timeout_s``: recorded anyway and
flagged ``settled = 0``) and **records** the reading as ``y`` (m, frame W). Occluded
(NaN) frames are left out; a marker unseen for ``max_occlusion_s`` raises
:class:`MocapError`. Without waiting (``wait=False``) it records the first valid reading
``dwell_s`` after the motors arrive. :func:`lab.capture.session.capture` runs it over a list
of commands with a journal. Defaults and their reasons: ``docs/design/rig.md``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from lab.capture.markers import frame_markers, mean_markers, reset_command
from lab.errors import InputError
from lab.rig.base import MocapError, Rig, RigError


@dataclass(frozen=True)
class Protocol:
    """Capture settings (SI units); the defaults are the protocol of the shipped data.

    Attributes
    ----------
    wait : bool
        Wait until settled (True) or record ``dwell_s`` after the motors arrive (False).
    reset : bool
        Erase hysteresis before each command (contract to ``reset_u_rad``, release to 0).
    n_previous : int
        Readings the settle test compares the current one with.
    reading_period_s : float
        One reading is the mean of the valid frames over this period (s).
    settle_tol_m : float
        Settled when the reading is within this distance (m) of the previous ones' mean.
    settle_timeout_s : float
        Not settled within this time (s) after the command: recorded and flagged.
    dwell_s : float
        Without waiting: pause (s) after the motors arrive before recording.
    reset_u_rad : float
        Motor angle (rad) every cable is contracted to by the reset.
    motor_tol_rad : float
        The motors arrived when every one is within this angle (rad) of its goal.
    motion_timeout_s : float
        Motors not arrived within this time (s): RigError.
    max_occlusion_s : float
        Tip marker unseen for longer (s): MocapError.
    kind : str
        One of :data:`PROTOCOLS`: ``wait`` (the paper's: settle, then record) or
        ``predictive`` (:mod:`lab.capture.predictive`).
    predict_tol_m : float
        Predictive: record when the predicted tip's 3-D std (m) is below this.
    n_learn : int
        Predictive: samples measured by waiting, to learn the relaxation from.
    n_modes : int
        Predictive: relaxation modes learned.
    process_noise_m2_per_s : float
        Predictive: random walk of the relaxation modes in the filter (model error), m^2/s.
    min_readings_after_arrival : int
        Predictive: readings after the motors arrived before a prediction is recorded.
    pose_jitter_m : float
        Predictive: how much the rest pose may differ from one visit to the next, m per axis.
    reset_jitter_m : float
        Predictive: the same for the reset pose (it keeps the previous sample's cable
        play), m per axis.
    """

    wait: bool = True
    reset: bool = True
    n_previous: int = 20
    reading_period_s: float = 0.1
    settle_tol_m: float = 1e-4
    settle_timeout_s: float = 60.0
    dwell_s: float = 0.5
    reset_u_rad: float = 1.0
    motor_tol_rad: float = 0.01
    motion_timeout_s: float = 30.0
    max_occlusion_s: float = 2.0
    kind: str = "wait"
    predict_tol_m: float = 1.5e-4
    n_learn: int = 10
    n_modes: int = 2
    process_noise_m2_per_s: float = 1e-8
    min_readings_after_arrival: int = 1
    pose_jitter_m: float = 1e-4
    reset_jitter_m: float = 2e-3

    def __post_init__(self):
        for name in (
            "reading_period_s",
            "settle_tol_m",
            "settle_timeout_s",
            "motor_tol_rad",
            "motion_timeout_s",
            "max_occlusion_s",
        ):
            if not getattr(self, name) > 0:
                raise InputError(f"protocol field '{name}' must be positive, got {getattr(self, name)!r}")
        if self.n_previous < 1 or self.dwell_s < 0 or self.reset_u_rad < 0:
            raise InputError("protocol needs n_previous >= 1, dwell_s >= 0 and reset_u_rad >= 0")
        if self.kind not in PROTOCOLS:
            raise InputError(f"protocol must be one of {', '.join(PROTOCOLS)}, got {self.kind!r}")
        if self.kind == "predictive":
            if not (self.predict_tol_m > 0 and self.n_learn >= 1 and self.n_modes >= 1):
                raise InputError("a predictive protocol needs predict_tol_m > 0, n_learn >= 1 and n_modes >= 1")
            if not (self.wait and self.reset):
                raise InputError("the predictive protocol replaces waiting; it cannot run without wait or reset")
            if (
                self.process_noise_m2_per_s < 0
                or self.min_readings_after_arrival < 1
                or min(self.pose_jitter_m, self.reset_jitter_m) < 0
            ):
                raise InputError("a predictive protocol needs process_noise_m2_per_s >= 0 and min readings >= 1")

    def as_dict(self) -> dict:
        """The settings, for metadata and journal headers.

        Returns
        -------
        dict
            Field -> value; a waiting protocol lists only the fields it uses, so journals
            written before the predictive protocol still resume.
        """
        d = asdict(self)
        if self.kind == "wait":
            for name in PREDICTIVE_FIELDS:
                d.pop(name)
        return d


#: capture protocols by name (``capture --protocol``)
PROTOCOLS = ("wait", "predictive")
PREDICTIVE_FIELDS = (
    "kind",
    "predict_tol_m",
    "n_learn",
    "n_modes",
    "process_noise_m2_per_s",
    "min_readings_after_arrival",
    "pose_jitter_m",
    "reset_jitter_m",
)


class SettleDetector:
    """The paper's test: the current reading is within ``tol_m`` of the mean of the
    previous ``n_previous`` readings. NaN readings are ignored.

    Parameters
    ----------
    n_previous : int
        How many previous readings the current one is compared with.
    tol_m : float
        Largest distance (m) from their mean that counts as settled.
    """

    def __init__(self, n_previous: int = 20, tol_m: float = 1e-4):
        self.n_previous, self.tol_m = int(n_previous), float(tol_m)
        self._history: list[np.ndarray] = []
        self.deviation_m = np.inf  # |current - mean(previous)| at the last update, m

    def update(self, reading_W: np.ndarray) -> bool:
        """Add a reading and test it.

        Parameters
        ----------
        reading_W : numpy.ndarray
            The reading, shape (3,), in m in frame W; NaN (occluded) is ignored.

        Returns
        -------
        bool
            True when it is within ``tol_m`` of the previous ``n_previous`` readings' mean.
        """
        reading_W = np.asarray(reading_W, dtype=float)
        if not np.all(np.isfinite(reading_W)):
            return False
        previous = self._history[-self.n_previous :]
        self._history.append(reading_W)
        if len(previous) < self.n_previous:
            return False
        self.deviation_m = float(np.linalg.norm(reading_W - np.mean(previous, axis=0)))
        return self.deviation_m <= self.tol_m


@dataclass
class Sample:
    """One recorded sample: command, tip, present motor angles, times on the rig clock (s),
    settle statistics.

    Attributes
    ----------
    u_motor : numpy.ndarray
        The command sent, shape (m,), in rad.
    p_tip_W : numpy.ndarray
        The recorded tip, shape (3,), in m in frame W.
    u_present : numpy.ndarray
        Present motor angles at the end, shape (m,), in rad.
    settled : bool
        Whether the settle test (or the prediction) passed; False: flagged.
    t_start_s, t_command_s, t_arrived_s, t_done_s : float
        Rig-clock times (s): start (before the reset), command sent, motors arrived, recorded.
    n_readings : int
        Readings taken after the command.
    deviation_m : float
        The settle test's last deviation (m); NaN without waiting.
    n_frames, n_invalid_frames : int
        Frames read for this sample, and how many of them were occluded.
    pred_std_m : float
        Predictive protocol: 3-D std (m) of the predicted settled tip (NaN when waited for).
    predicted : bool
        Predictive protocol: recorded from the prediction (False: waited for).
    markers_W : numpy.ndarray or None
        Every marker of the robot (the tip first) at the recorded reading, shape (K, 3),
        m, frame W (each the mean of its valid frames, NaN if unseen); None for a robot
        observed at its tip alone.
    """

    u_motor: np.ndarray
    p_tip_W: np.ndarray
    u_present: np.ndarray
    settled: bool
    t_start_s: float
    t_command_s: float
    t_arrived_s: float
    t_done_s: float
    n_readings: int
    deviation_m: float
    n_frames: int
    n_invalid_frames: int
    pred_std_m: float = float("nan")
    predicted: bool = False
    markers_W: np.ndarray | None = None


class _Watcher:
    """Readings (mean of valid frames over one period) from a rig, with frame counts
    and the occlusion check."""

    def __init__(self, rig: Rig, protocol: Protocol):
        self.rig, self.protocol = rig, protocol
        self.n_frames = self.n_invalid = 0
        self._t_seen = rig.now()
        self.n_markers = len(rig.robot.marker_names)
        self.markers_W = None  # the last reading of every marker (K, 3), for a robot with markers

    def read(self) -> np.ndarray:
        end = self.rig.now() + self.protocol.reading_period_s
        points, markers = [], []
        while self.rig.now() < end - 1e-9:
            frame = self.rig.next_frame()
            self.n_frames += 1
            if frame.valid:
                points.append(frame.p_tip_W)
                if self.n_markers > 1:
                    markers.append(frame_markers(frame, self.n_markers, self.rig.kind))
                self._t_seen = frame.t_s
            else:
                self.n_invalid += 1
                if frame.t_s - self._t_seen > self.protocol.max_occlusion_s:
                    raise MocapError(
                        f"tip marker not seen for {frame.t_s - self._t_seen:.1f} s "
                        f"(limit {self.protocol.max_occlusion_s} s)"
                    )
        if self.n_markers > 1:
            self.markers_W = mean_markers(markers, self.n_markers)
        return np.mean(points, axis=0) if points else np.full(3, np.nan)

    def arrived(self, goal: np.ndarray) -> bool:
        return bool(np.all(np.abs(self.rig.present_u() - goal) <= self.protocol.motor_tol_rad))

    def go_to(self, u_motor: np.ndarray) -> None:
        """Send ``u_motor`` and watch until the motors report it."""
        goal = self.rig.send(u_motor)
        t0 = self.rig.now()
        while not self.arrived(goal):
            if self.rig.now() - t0 > self.protocol.motion_timeout_s:
                raise RigError(
                    f"motors did not reach {goal.tolist()} rad within {self.protocol.motion_timeout_s} s "
                    f"(present {self.rig.present_u().tolist()} rad)"
                )
            self.read()


def measure(rig: Rig, u_motor, protocol: Protocol = Protocol()) -> Sample:
    """Capture one sample of command ``u_motor`` with ``protocol`` (reset, move, wait, record).

    Parameters
    ----------
    rig : Rig
        The rig to measure on.
    u_motor : array_like
        The command, shape (m,), in rad (validated by the rig).
    protocol : Protocol
        The capture settings.

    Returns
    -------
    Sample
        The recorded sample (RigError if the motors do not arrive, MocapError if the
        marker stays unseen).
    """
    watch = _Watcher(rig, protocol)
    t_start = rig.now()
    if protocol.reset:
        m = rig.robot.n_inputs
        watch.go_to(reset_command(rig.robot, protocol))  # contract all together ...
        watch.go_to(np.zeros(m))  # ... and release
    goal = rig.send(u_motor)
    t_command = rig.now()
    detector = SettleDetector(protocol.n_previous, protocol.settle_tol_m)
    t_arrived, last_valid, settled, n_readings = None, None, False, 0
    last_markers = None
    while True:
        reading = watch.read()
        n_readings += 1
        valid = bool(np.all(np.isfinite(reading)))
        if valid:
            last_valid, last_markers = reading, watch.markers_W
        if t_arrived is None:
            if watch.arrived(goal):
                t_arrived = rig.now()
            elif rig.now() - t_command > protocol.motion_timeout_s:
                raise RigError(
                    f"motors did not reach {goal.tolist()} rad within {protocol.motion_timeout_s} s "
                    f"(present {rig.present_u().tolist()} rad)"
                )
        if protocol.wait:
            settled = detector.update(reading)
            if t_arrived is not None and (
                settled or (rig.now() - t_command > protocol.settle_timeout_s and last_valid is not None)
            ):
                break  # settled, or flagged (settled = False)
        elif t_arrived is not None and rig.now() - t_arrived >= protocol.dwell_s and valid:
            break  # fixed pause: settling not checked
    return Sample(
        goal,
        last_valid,
        rig.present_u(),
        bool(settled),
        t_start,
        t_command,
        t_arrived,
        rig.now(),
        n_readings,
        detector.deviation_m if protocol.wait else float("nan"),
        watch.n_frames,
        watch.n_invalid,
        markers_W=last_markers,
    )
