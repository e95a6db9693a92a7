"""Recording what a rig does in time: commands as equilibrium ramps, and the tip as readings.

:class:`StreamRecorder` drives a rig and keeps a :class:`~lab.dynamics.relaxation_fit.Stream`:
each command is a :class:`~lab.dynamics.relaxation_fit.Segment` (sent at ``t_command_s``,
motors arrived at ``t_arrived_s``), each reading the mean of the valid motion-capture
frames over ``reading_period_s`` at their mean time. Motors are assumed to turn at constant
speed (Dynamixel "Profile Acceleration = 0") and to arrive together (the hardware driver
scales each servo's speed to its travel), so the motor angles move on a straight line, the
fraction of the move done is known from the present angles read after each reading, and
the arrival time is interpolated between readings rather than rounded up to one. Both the
relaxation fit (``python -m lab fit-dynamics``) and the predictive capture protocol use it.
"""

from __future__ import annotations

import numpy as np

from lab.capture.pace import PaceMeter
from lab.dynamics.relaxation_fit import Segment, Stream
from lab.rig.base import MocapError, Rig, RigError


class _Move:
    """One command in progress: start and goal angles (rad), progress points (t, fraction)."""

    def __init__(self, t_command_s, u_start, goal, pose, motor_tol_rad):
        self.t_command_s, self.pose = float(t_command_s), pose
        self.u_start, self.goal = np.asarray(u_start, float), np.asarray(goal, float)
        self.travel = float(np.max(np.abs(self.goal - self.u_start)))
        self.tol = motor_tol_rad
        self.t_arrived_s = self.t_command_s if self.travel <= motor_tol_rad else None
        self._speed = None  # fraction per second

    def observe(self, t_s: float, u_present) -> None:
        if self.t_arrived_s is not None:
            return
        remaining = float(np.max(np.abs(self.goal - np.asarray(u_present, float))))
        fraction = 1.0 - remaining / self.travel
        if remaining <= self.tol:
            dt = t_s - self.t_command_s
            # arrived during the last reading: from the speed seen so far, or at its middle
            t_arr = self.t_command_s + 1.0 / self._speed if self._speed else t_s - 0.5 * min(dt, 0.1)
            self.t_arrived_s = float(min(max(t_arr, self.t_command_s), t_s))
        elif fraction > 0 and t_s > self.t_command_s:
            self._speed = fraction / (t_s - self.t_command_s)

    def fraction(self, t_s: float) -> float:
        """Fraction (0..1) of the move done at ``t_s`` (extrapolated at the speed seen)."""
        if self.t_arrived_s is not None:
            span = self.t_arrived_s - self.t_command_s
            return 1.0 if span <= 0 else float(np.clip((t_s - self.t_command_s) / span, 0.0, 1.0))
        return float(np.clip((self._speed or 0.0) * (t_s - self.t_command_s), 0.0, 1.0))

    @property
    def arrived(self) -> bool:
        return self.t_arrived_s is not None


class StreamRecorder:
    """Drive ``rig`` and record its stream: the readings ``t_s``, ``p_tip_W`` and ``n_valid``
    (NaN tip and 0 frames when the marker was not seen) and the commands ``moves``;
    ``meter`` (:class:`~lab.capture.pace.PaceMeter`) times every frame read.

    Parameters
    ----------
    rig : Rig
        The rig to drive and read.
    reading_period_s : float
        One reading is the mean of the valid frames over this period (s).
    max_occlusion_s : float
        Tip marker unseen for longer (s): MocapError.
    motor_tol_rad : float
        The motors arrived when every one is within this angle (rad) of its goal.
    initial_pose : str
        Label of the equilibrium before the first command.
    """

    def __init__(
        self,
        rig: Rig,
        reading_period_s: float = 0.1,
        max_occlusion_s: float = 2.0,
        motor_tol_rad: float = 0.01,
        initial_pose: str = "initial",
    ):
        self.rig = rig
        self.reading_period_s, self.max_occlusion_s = float(reading_period_s), float(max_occlusion_s)
        self.motor_tol_rad = float(motor_tol_rad)
        self.initial_pose = initial_pose
        self.moves: list[_Move] = []
        self.t_s, self.p_tip_W, self.n_valid = [], [], []
        self.n_frames = self.n_invalid = 0
        self.meter = PaceMeter(rig.frame_rate_hz)
        self._t_seen = rig.now()
        self._u_present = rig.present_u()

    @property
    def move(self) -> _Move | None:
        """The latest command."""
        return self.moves[-1] if self.moves else None

    def command(self, u_motor, pose: str) -> np.ndarray:
        """Send a command and start recording its move (returns at once).

        Parameters
        ----------
        u_motor : array_like
            The command, shape (m,), in rad (validated by the rig).
        pose : str
            Label of the equilibrium it moves to (e.g. ``reset``, ``rest``, ``target``).

        Returns
        -------
        numpy.ndarray
            The validated goal, shape (m,), in rad.
        """
        goal = self.rig.send(u_motor)
        self.moves.append(_Move(self.rig.now(), self._u_present, goal, str(pose), self.motor_tol_rad))
        return goal

    def read(self) -> tuple[float, np.ndarray, int]:
        """Take one reading (frames over ``reading_period_s``), then read the motors.

        Returns
        -------
        t_mid_s : float
            Mean time (s, rig clock) of the valid frames (mid-period when none).
        p_tip_W : numpy.ndarray
            Mean tip, shape (3,), in m in frame W, or NaN when the marker was not seen.
        n_valid : int
            Valid frames used.
        """
        end = self.rig.now() + self.reading_period_s
        points, times = [], []
        while self.rig.now() < end - 1e-9:
            frame = self.rig.next_frame()
            self.n_frames += 1
            self.meter.add(frame.t_s)
            if frame.valid:
                points.append(frame.p_tip_W)
                times.append(frame.t_s)
                self._t_seen = frame.t_s
            else:
                self.n_invalid += 1
                if frame.t_s - self._t_seen > self.max_occlusion_s:
                    raise MocapError(
                        f"tip marker not seen for {frame.t_s - self._t_seen:.1f} s (limit {self.max_occlusion_s} s)"
                    )
        self._u_present = self.rig.present_u()
        if self.moves:
            self.move.observe(self.rig.now(), self._u_present)
        if points:
            t_mid, p = float(np.mean(times)), np.mean(points, axis=0)
        else:
            t_mid, p = self.rig.now() - 0.5 * self.reading_period_s, np.full(3, np.nan)
        self.t_s.append(t_mid)
        self.p_tip_W.append(p)
        self.n_valid.append(len(points))
        return t_mid, p, len(points)

    def go_to(self, u_motor, pose: str, timeout_s: float = 30.0) -> np.ndarray:
        """Command ``u_motor`` and read until the motors have arrived.

        Parameters
        ----------
        u_motor : array_like
            The command, shape (m,), in rad.
        pose : str
            Label of its equilibrium.
        timeout_s : float
            Motors not arrived within this time (s, rig clock): RigError.

        Returns
        -------
        numpy.ndarray
            The validated goal, shape (m,), in rad.
        """
        goal = self.command(u_motor, pose)
        while not self.move.arrived:
            if self.rig.now() - self.move.t_command_s > timeout_s:
                raise RigError(
                    f"motors did not reach {goal.tolist()} rad within {timeout_s} s "
                    f"(present {self.rig.present_u().tolist()} rad)"
                )
            self.read()
        return goal

    def hold(self, duration_s: float) -> None:
        """Read for ``duration_s`` seconds.

        Parameters
        ----------
        duration_s : float
            How long to read (s, rig clock).
        """
        t_end = self.rig.now() + float(duration_s)
        while self.rig.now() < t_end - 1e-9:
            self.read()

    @property
    def present_u(self) -> np.ndarray:
        """Motor angles (m,) rad read after the latest reading."""
        return self._u_present

    def stream(self, since: int = 0) -> Stream:
        """The recording as a :class:`Stream` (commands from number ``since`` on, and the
        readings from that command's time; the pose before it is the previous command's).

        Parameters
        ----------
        since : int
            Index of the first command to include.

        Returns
        -------
        Stream
            Reading times (N,) s, tips (N, 3) m, valid-frame counts (N,), one
            :class:`Segment` per command and the pose before the first.
        """
        moves = self.moves[since:]
        t0 = moves[0].t_command_s if moves else -np.inf
        keep = np.asarray(self.t_s) >= t0
        segments = [Segment(m.t_command_s, m.t_arrived_s if m.arrived else m.t_command_s, m.pose) for m in moves]
        initial = self.moves[since - 1].pose if since > 0 else self.initial_pose
        return Stream(
            np.asarray(self.t_s)[keep],
            np.asarray(self.p_tip_W).reshape(-1, 3)[keep],
            np.asarray(self.n_valid)[keep],
            segments,
            initial,
        )
