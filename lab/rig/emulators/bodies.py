"""Bodies for the hardware emulators.

``LiveBody`` puts a ``Body`` (``lab.rig.base``) on a clock (the wall clock, or a
``VirtualClock``) so that the emulated servo bus (which commands it) and the NatNet server
(which streams its tip) can share it from their own threads: calls are serialised by a
lock and time never runs backward (a command stamped before the body's latest time is
applied at that time). A body with a ``profile_velocity_rad_s`` attribute gets the servos'
speeds with each command: the fastest as ``profile_velocity_rad_s`` and, where it has a
``motor_speeds_rad_s`` attribute, each motor's own, so its motors move as the servos the
driver configured do (each at its own speed: the driver scales them to arrive together).

``KinematicBody`` is a small stand-in for the arm, for exercising the hardware path
without the FEM: each motor turns toward its goal at a fixed speed, and the tip moves
linearly with the motor angles, ``p_tip_W = p_rest_W + J_W @ u_present``.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from lab.errors import InputError
from lab.rig.base import Body


class LiveBody:
    """A ``Body`` driven on ``clock`` (s; default the wall clock), ``t_s`` = seconds since
    construction.

    Parameters
    ----------
    body : Body
        The body to share between the emulators' threads.
    clock : callable
        Returns the time (s); ``time.monotonic`` or a :class:`VirtualClock`.
    """

    def __init__(self, body: Body, clock=time.monotonic):
        self.body = body
        self._clock = clock
        self._t0 = clock()
        self._t_last = 0.0
        self._lock = threading.Lock()

    def now(self) -> float:
        """The body's time.

        Returns
        -------
        float
            Seconds (on ``clock``) since construction.
        """
        return self._clock() - self._t0

    def _tick(self, t_s: float | None = None) -> float:
        self._t_last = max(self._t_last, self.now() if t_s is None else float(t_s))
        return self._t_last

    def command(self, u_goal_rad, t_s: float | None = None, profile_velocity_rad_s=None) -> None:
        """New goal motor angles (n_motors,) rad from ``t_s`` (default now; s on this
        clock) on, with the motors' speeds where the body has a speed limit:
        ``profile_velocity_rad_s`` rad/s, one for all or (n_motors,) one per motor (with
        any of them 0, a servo that does not drive, the speeds stay as they were).

        Parameters
        ----------
        u_goal_rad : array_like
            Goal motor angles, shape (n_motors,), in rad.
        t_s : float, optional
            Time (s on this clock) from which the goal holds; now when omitted, and never
            before the body's latest time.
        profile_velocity_rad_s : float or array_like, optional
            Motor speed (rad/s), one for all or shape (n_motors,); None keeps the speeds.
        """
        with self._lock:
            t = self._tick(t_s)
            v = None if profile_velocity_rad_s is None else np.asarray(profile_velocity_rad_s, dtype=float)
            if v is not None and np.all(v > 0) and hasattr(self.body, "profile_velocity_rad_s"):
                self.body.state(t)  # the motion so far, at the speeds it had
                self.body.profile_velocity_rad_s = float(v.max())
                if hasattr(self.body, "motor_speeds_rad_s"):
                    self.body.motor_speeds_rad_s = v.copy() if v.ndim == 1 else None
            self.body.command(np.asarray(u_goal_rad, dtype=float), t)

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """The body's state now.

        Returns
        -------
        u_present_rad : numpy.ndarray
            Present motor angles, shape (n_motors,), in rad.
        p_tip_W : numpy.ndarray
            Tip position, shape (3,), in m in the frame W.
        """
        with self._lock:
            return self.body.state(self._tick())

    def p_tip_W(self, _t_s: float | None = None) -> np.ndarray:
        """The tip position (3,) m now, as the body gives it (an ``AsBuiltBody``: where the
        room-registered motion capture sees it, with its defects file's base tilt and frame
        error; the argument is ignored: a NatNet tip source).

        Parameters
        ----------
        _t_s : float, optional
            Ignored (the signature of a NatNet tip source).

        Returns
        -------
        numpy.ndarray
            Tip position p_tip_W, shape (3,), in m.
        """
        return self.state()[1]


class KinematicBody(Body):
    """Motors slewing at ``profile_velocity_rad_s`` (or each at ``motor_speeds_rad_s``
    (n_motors,) rad/s when set) toward their goals; tip linear in the angles. The last goal
    and the motor angles are kept for inspection.

    Parameters
    ----------
    p_rest_W : array_like
        Tip at u = 0, shape (3,), in m in the frame W.
    J_W : array_like
        Tip displacement per motor angle, shape (3, n_motors), in m/rad.
    profile_velocity_rad_s : float
        Motor speed (rad/s), positive.
    """

    def __init__(self, p_rest_W, J_W, profile_velocity_rad_s: float = 2.0):
        self.p_rest_W = np.asarray(p_rest_W, dtype=float).reshape(3)
        self.J_W = np.asarray(J_W, dtype=float)
        if self.J_W.ndim != 2 or self.J_W.shape[0] != 3:
            raise InputError(f"J_W must have shape (3, n_motors), got {self.J_W.shape}")
        if not profile_velocity_rad_s > 0:
            raise InputError(f"profile_velocity_rad_s must be positive, got {profile_velocity_rad_s}")
        self.n_motors = self.J_W.shape[1]
        self.profile_velocity_rad_s = float(profile_velocity_rad_s)
        self.motor_speeds_rad_s: np.ndarray | None = None
        self.u_goal_rad = np.zeros(self.n_motors)
        self.u_rad = np.zeros(self.n_motors)
        self._t_s = 0.0

    def _advance(self, t_s: float) -> None:
        dt = max(0.0, t_s - self._t_s)
        self._t_s = max(self._t_s, t_s)
        err = self.u_goal_rad - self.u_rad
        speed = self.profile_velocity_rad_s if self.motor_speeds_rad_s is None else self.motor_speeds_rad_s
        step = speed * dt
        self.u_rad = self.u_rad + np.clip(err, -step, step)

    def command(self, u_goal_rad: np.ndarray, t_s: float) -> None:
        u = np.asarray(u_goal_rad, dtype=float)
        if u.shape != (self.n_motors,):
            raise InputError(f"expected {self.n_motors} motor angles, got shape {u.shape}")
        self._advance(t_s)
        self.u_goal_rad = u.copy()

    def state(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        self._advance(t_s)
        return self.u_rad.copy(), self.p_rest_W + self.J_W @ self.u_rad
