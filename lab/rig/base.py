"""The rig interface: send motor angles, read a stream of tip-marker frames, stop safely.

One interface, three implementations, built by :func:`lab.rig.make_rig`: ``sim``
(:class:`~lab.rig.sim.SimRig`, the nominal quasi-static FEM), ``twin`` (the emulated
as-built robot, :mod:`lab.rig.twin`) and ``hardware`` (:mod:`lab.rig.hardware`). Capture
and tracking use only this interface::

    with make_rig("twin", robot) as rig:
        rig.send(u_motor)                 # rad, validated by the robot's limits and safety rule
        frame = rig.next_frame()          # MocapFrame(t_s, p_tip_W), NaN while occluded

``close()`` (also run by ``with`` on any exception) leaves the robot safe: torque off on
hardware. Frames are stamped on the rig's clock (s): wall time on hardware, a virtual
clock on the emulated rigs. More in ``docs/design/rig.md``.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np

from lab.description import RobotDescription
from lab.errors import LabRuntimeError


class RigError(LabRuntimeError):
    """A rig stopped working (the rig has been made safe before this is raised)."""


class ServoError(RigError):
    """A servo stopped answering, answered garbage, or reported a hardware error."""


class MocapError(RigError):
    """The motion-capture stream was lost, or the tip marker stayed occluded too long."""


@dataclass(frozen=True)
class MocapFrame:
    """One motion-capture frame: the tip marker's position at one time on the rig clock.

    Attributes
    ----------
    t_s : float
        Time stamp (s) on the rig's clock.
    p_tip_W : numpy.ndarray
        Tip marker position, shape (3,), in m in the robot frame W; all-NaN when the
        marker was not seen in this frame.
    markers_W : numpy.ndarray or None
        Every observed point of the robot (``robot.marker_names``: the tip first), shape
        (K, 3), m, frame W, on a rig that observes them all (the simulated rig); None on a
        rig that sees the tip alone.
    """

    t_s: float
    p_tip_W: np.ndarray
    markers_W: np.ndarray | None = None

    @property
    def valid(self) -> bool:
        return bool(np.all(np.isfinite(self.p_tip_W)))


class Rig(abc.ABC):
    """Base class of all rigs. Subclasses implement the ``_send``/``next_frame``/... hooks.

    Parameters
    ----------
    robot : RobotDescription
        The robot the rig drives; its limits and safety rule validate every command.
    frame_rate_hz : float
        Motion-capture frame rate (Hz): one :class:`MocapFrame` per ``1 / frame_rate_hz`` s.
    """

    #: short name written into datasets and reports ("sim", "twin", "hardware")
    kind: str = "rig"

    def __init__(self, robot: RobotDescription, frame_rate_hz: float):
        self.robot = robot
        self.frame_rate_hz = float(frame_rate_hz)
        self._closed = False

    # --- commands -------------------------------------------------------------------
    def send(self, u_motor) -> np.ndarray:
        """Set the goal motor angles ``u_motor`` (n_cables,) rad and return at once.

        Raises ValueError (nothing is sent) for a wrong shape, NaN, an angle outside
        ``[0, u_max]`` or a command the robot's safety rule forbids.

        Parameters
        ----------
        u_motor : array_like
            Goal motor angles, shape (n_cables,), in rad.

        Returns
        -------
        numpy.ndarray
            The validated command that was sent, shape (n_cables,), rad (float).
        """
        if self._closed:
            raise RigError(f"{self.kind} rig is closed")
        u = self.robot.check_command(u_motor)
        self._send(u)
        return u

    @abc.abstractmethod
    def _send(self, u_motor: np.ndarray) -> None:
        """Send an already validated command."""

    @abc.abstractmethod
    def present_u(self) -> np.ndarray:
        """Measured motor angles.

        Returns
        -------
        numpy.ndarray
            Present motor angles, shape (n_cables,), in rad (read from the servos on
            hardware, the emulated motors' state on the twin, the last command on sim).
        """

    # --- sensing --------------------------------------------------------------------
    @abc.abstractmethod
    def now(self) -> float:
        """Current time on the rig's clock.

        Returns
        -------
        float
            Time (s): wall time on hardware, the virtual clock on emulated rigs.
        """

    @abc.abstractmethod
    def next_frame(self) -> MocapFrame:
        """The next motion-capture frame (blocks on hardware; advances a virtual clock by
        one frame period on emulated rigs).

        Returns
        -------
        MocapFrame
            Time stamp (s) and tip marker ``p_tip_W`` (3,) m in W; NaN while occluded.
        """

    def frames(self, n: int) -> list[MocapFrame]:
        """The next ``n`` frames.

        Parameters
        ----------
        n : int
            Number of frames to read.

        Returns
        -------
        list of MocapFrame
            ``n`` consecutive frames, oldest first.
        """
        return [self.next_frame() for _ in range(int(n))]

    def wait(self, duration_s: float) -> list[MocapFrame]:
        """Let ``duration_s`` seconds pass on the rig clock, consuming (and returning) the
        frames that arrive meanwhile.

        Parameters
        ----------
        duration_s : float
            How long to wait (s, rig clock).

        Returns
        -------
        list of MocapFrame
            The frames read until the clock reached ``now() + duration_s``, oldest first.
        """
        t_end = self.now() + float(duration_s)
        out = []
        while self.now() < t_end - 1e-12:
            out.append(self.next_frame())
        return out

    # --- shutdown -------------------------------------------------------------------
    def close(self) -> None:
        """Make the robot safe and release the connection. Idempotent."""
        if not self._closed:
            self._closed = True
            self._close()

    def _close(self) -> None:  # noqa: B027 (a hook: rigs with hardware override it)
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def describe(self) -> dict:
        """JSON-able description of this rig for dataset/report metadata.

        Returns
        -------
        dict
            ``kind``, ``robot`` (name) and ``frame_rate_hz`` (Hz), plus what the rig adds.
        """
        return {"kind": self.kind, "robot": self.robot.name, "frame_rate_hz": self.frame_rate_hz}


class Body(abc.ABC):
    """The physical arm an emulator stands in for, on a clock ``t_s`` (s).

    The emulated rig (``twin``) and the hardware emulators (an XM430 bus on a
    pseudo-terminal, a NatNet server on loopback) drive the same body, so the whole
    hardware path can run against the emulated robot. Calls come with non-decreasing
    ``t_s``; the body integrates its own dynamics (motor profile, lag, hysteresis) up
    to that time.
    """

    n_motors: int

    @abc.abstractmethod
    def command(self, u_goal_rad: np.ndarray, t_s: float) -> None:
        """New goal motor angles from time ``t_s`` on.

        Parameters
        ----------
        u_goal_rad : numpy.ndarray
            Goal motor angles, shape (n_motors,), in rad.
        t_s : float
            Time (s, body clock) the goal takes effect; not before earlier calls.
        """

    @abc.abstractmethod
    def state(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The body's state at ``t_s``, after integrating its dynamics up to then.

        Parameters
        ----------
        t_s : float
            Time (s, body clock); not before earlier calls.

        Returns
        -------
        u_present_rad : numpy.ndarray
            Present motor angles, shape (n_motors,), in rad.
        p_tip_W : numpy.ndarray
            True tip position, shape (3,), in m in the robot frame W.
        """
