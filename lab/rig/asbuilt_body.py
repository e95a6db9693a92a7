"""``AsBuiltBody``: the emulated as-built arm in time, at every marker.

A :class:`~lab.rig.base.Body` that the twin rig (:mod:`lab.rig.twin`) and the hardware
emulators drive. From a command to the markers: motor goals rounded to encoder ticks and
reached at the profile velocity (a tension-controlled tendon's tension is held at once, not
in ticks, with no play); a Prandtl play of half-width ``h`` on each cable's contraction
(hysteresis, erased by the capture protocol's reset); the as-built FEM solved once per
command (:class:`~lab.asbuilt.equilibria.EquilibriumCache`), every marker's equilibrium
moving linearly while the motors turn; the foam's lag, two first-order modes integrated
exactly (three with the defects file's creep), the same for every marker; and where the
motion capture sees them (:meth:`AsBuiltBody.report`: the base's tilt, the mocap's frame
error, alike for every marker). The tip is computed exactly as before markers existed.
The model step by step: ``docs/design/rig.md``.
"""

from __future__ import annotations

import math

import numpy as np

from lab.asbuilt.arm import Defects, EquilibriumCache, as_built_fem, load_defects
from lab.asbuilt.equilibria import input_scale
from lab.description import RobotDescription
from lab.errors import InputError
from lab.rig.base import Body

__all__ = ["AsBuiltBody"]


class AsBuiltBody(Body):
    """The as-built arm in time (see the module docstring).

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot (cables, spool radius, limits).
    defects : Defects or str or None
        The as-built defects: a :class:`Defects`, a TOML path, or None for the robot's
        shipped default.
    n_rings, n_axial : int, optional
        Override the FEM mesh's rings and axial layers (coarse meshes for tests).
    """

    def __init__(
        self,
        robot: RobotDescription,
        defects: Defects | str | None = None,
        *,
        n_rings: int | None = None,
        n_axial: int | None = None,
    ):
        self.robot = robot
        self.defects = defects if isinstance(defects, Defects) else load_defects(defects, robot)
        self.fem = as_built_fem(robot, self.defects, n_rings=n_rings, n_axial=n_axial)
        self.equilibria = EquilibriumCache(self.fem)
        self.n_motors = robot.n_inputs
        #: motor speed (rad/s) used for the next command; the XM430 emulator may set it
        self.profile_velocity_rad_s = self.defects.profile_velocity_rad_s
        #: or each motor's (n_motors,) rad/s (the XM430 emulator's servos); None: all at the above
        self.motor_speeds_rad_s: np.ndarray | None = None
        d = self.defects
        #: tension-controlled inputs (n_motors,) bool, or None when every input is an angle
        self._held = None if robot.all_angle else np.array([c.control == "tension" for c in robot.cables])
        self._r = input_scale(robot)
        self._h = d.play_m if self._held is None else np.where(self._held, 0.0, d.play_m)
        self._tick = 2 * math.pi / d.ticks_per_rev if d.ticks_per_rev else 0.0
        if d.creep_fraction > 0:  # a third, slow mode (creep)
            self._w = np.array([1.0 - d.slow_fraction - d.creep_fraction, d.slow_fraction, d.creep_fraction])
            self._tau = np.array([d.tau_fast_s, d.tau_slow_s, d.creep_tau_s])
        else:
            self._w = np.array([1.0 - d.slow_fraction, d.slow_fraction])
            self._tau = np.array([d.tau_fast_s, d.tau_slow_s])
        R_tilt, R_frame = d.R_tilt, d.R_frame
        self._R_report = R_tilt if R_frame is None else (R_frame if R_tilt is None else R_frame @ R_tilt)
        self._offset_report = d.frame_offset_m if d.has_frame_offset else None
        #: the observed points (``robot.marker_names``: the tip first)
        self.marker_names = tuple(self.fem.marker_names)
        zero = np.zeros(self.n_motors)
        p_rest = self.equilibria.tip(zero)
        # Current motion segment, from t0: motors u0 -> goal at speed v, cables from y0,
        # equilibrium p0 -> p1 linearly over T seconds.
        self._t0, self._u0, self._goal, self._v = 0.0, zero.copy(), zero.copy(), self.profile_velocity_rad_s
        self._y0, self._p0, self._p1, self._T = zero.copy(), p_rest, p_rest, 0.0
        self._t = 0.0
        self._z = np.stack([p_rest] * len(self._w))  # lag modes (2 or 3, 3) in the body frame, settled
        # The other markers (K - 1 of them), flattened (3(K-1),), on the same ramp and lag.
        self._others = len(self.marker_names) > 1
        if self._others:
            m_rest = self._other_markers(zero)
            self._m0, self._m1 = m_rest, m_rest
            self._zm = np.stack([m_rest] * len(self._w))

    # ---------------------------------------------------------------- Body interface
    def command(self, u_goal_rad: np.ndarray, t_s: float) -> None:
        """New goal inputs from ``t_s`` on (any finite values; the rig, not the
        body, enforces the robot's range and safety rule).

        Parameters
        ----------
        u_goal_rad : numpy.ndarray
            Goal inputs, shape (n_motors,): motor angles in rad, rounded to encoder ticks
            and reached at the profile velocity; tensions in N (a tension-controlled
            tendon), held from ``t_s`` on.
        t_s : float
            Time (s, body clock) from which the goal holds; not before the body's time.
        """
        goal = np.asarray(u_goal_rad, dtype=float)
        if goal.shape != (self.n_motors,) or not np.all(np.isfinite(goal)):
            raise InputError(f"expected {self.n_motors} finite motor angles, got {goal!r}")
        self._advance(t_s)
        u_now, y_now, p_now = self._motors(self._t), self._contraction(self._t), self._input(self._t)
        goal = self._quantise(goal)
        y_end = np.clip(y_now, self._r * goal - self._h, self._r * goal + self._h)
        p_end = self.equilibria.tip(y_end)
        if self._others:
            self._m0, self._m1 = self._ramp(self._m0, self._m1, self._t), self._other_markers(y_end)
        v = float(self.profile_velocity_rad_s) if self.motor_speeds_rad_s is None else self.motor_speeds_rad_s
        if not np.all(np.asarray(v) > 0):
            raise InputError(f"motor speeds must be positive, got {v}")
        self._t0, self._u0, self._goal, self._v = self._t, u_now, goal, v
        self._y0, self._p0, self._p1 = y_now, p_now, p_end
        travel = np.abs(goal - u_now)
        if self._held is not None:  # a tension is held at once (a motor in torque mode)
            travel[self._held] = 0.0
        k = int(np.argmax(travel))  # the equilibrium ramps over the time of the farthest move
        self._T = float(travel[k] / (v if np.ndim(v) == 0 else v[k]))

    def state(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The motors and the tip at ``t_s``, after integrating the lag modes up to then.

        Parameters
        ----------
        t_s : float
            Time (s, body clock); not before the body's time.

        Returns
        -------
        u_present_rad : numpy.ndarray
            Present motor angles, shape (n_motors,), in rad, in whole encoder ticks.
        p_tip_W : numpy.ndarray
            Tip, shape (3,), in m, where the motion capture sees it before its noise
            (:meth:`report` of the body's tip).
        """
        self._advance(t_s)
        return self._quantise(self._motors(self._t)), self.report(self._w @ self._z)

    def markers(self, t_s: float) -> np.ndarray:
        """Every marker at ``t_s`` where the motion capture sees it before its noise.

        Parameters
        ----------
        t_s : float
            Time (s, body clock); not before the body's time.

        Returns
        -------
        numpy.ndarray
            The markers (``marker_names``, the tip first), shape (K, 3), m, frame W; row 0
            is :meth:`state`'s tip, bit for bit, and the base's tilt and the mocap's frame
            error move every marker alike (:meth:`report_points`).
        """
        tip = self.state(t_s)[1]
        if not self._others:
            return tip[None, :]
        others = (self._w @ self._zm).reshape(-1, 3)
        return np.vstack([tip, self.report_points(others)])

    # ---------------------------------------------------------------- helpers
    @property
    def time_s(self) -> float:
        """The body's clock: the latest time it was advanced to, s."""
        return self._t

    @property
    def contraction_m(self) -> np.ndarray:
        """Effective cable contractions y (n_motors,) m after the play, at the body's time."""
        return self._contraction(self._t)

    def contraction_from_reset(self, u_motor) -> np.ndarray:
        """Effective contractions when ``u_motor`` is approached from the reset state
        (every cable released to y = +h): ``max(h, r u - h)``.

        Parameters
        ----------
        u_motor : array_like
            Motor angles, shape (n_motors,), in rad (rounded to encoder ticks).

        Returns
        -------
        numpy.ndarray
            Cable contractions y after the play, shape (n_motors,), in m.
        """
        return np.maximum(self._h, self._r * self._quantise(np.asarray(u_motor, float)) - self._h)

    def quasi_static_tip(self, u_motor) -> np.ndarray:
        """Noise-free settled tip for ``u_motor`` reached after a reset: the quasi-static
        map the capture protocol measures (:meth:`report`, noise-free).

        Parameters
        ----------
        u_motor : array_like
            Motor angles, shape (n_motors,), in rad.

        Returns
        -------
        numpy.ndarray
            Settled tip p_tip_W, shape (3,), in m in the motion capture's frame W.
        """
        return self.report(self.equilibria.tip(self.contraction_from_reset(u_motor)))

    def quasi_static_markers(self, u_motor) -> np.ndarray:
        """Noise-free settled markers for ``u_motor`` reached after a reset (:meth:`quasi_static_tip`
        for every marker).

        Parameters
        ----------
        u_motor : array_like
            Inputs, shape (n_motors,): motor angles in rad, tensions in N.

        Returns
        -------
        numpy.ndarray
            Settled markers (the tip first, row 0 :meth:`quasi_static_tip`), shape (K, 3), m, frame W.
        """
        y = self.contraction_from_reset(u_motor)
        points = self.equilibria.markers(y)
        return np.vstack([self.report(self.equilibria.tip(y)), self.report_points(points[1:])])

    def report_points(self, points_body: np.ndarray) -> np.ndarray:
        """:meth:`report` of several points of the body frame at once.

        Parameters
        ----------
        points_body : numpy.ndarray
            Points, shape (P, 3), m, body (FEM) frame.

        Returns
        -------
        numpy.ndarray
            The points, shape (P, 3), m, in the motion capture's frame W.
        """
        p = np.asarray(points_body, dtype=float).reshape(-1, 3)
        p = p if self._R_report is None else p @ self._R_report.T
        return p if self._offset_report is None else p + self._offset_report

    def report(self, p_body: np.ndarray) -> np.ndarray:
        """Where the motion capture reports a point of the body frame (the FEM's):
        ``R_err (R_tilt p_body) + frame_offset_m`` -- the base tilted in the room (about its
        origin), the room's frame registered with an error. Without those defects, ``p_body``
        itself (bit for bit).

        Parameters
        ----------
        p_body : numpy.ndarray
            A point, shape (3,), in m in the body (FEM) frame.

        Returns
        -------
        numpy.ndarray
            The point, shape (3,), in m in the motion capture's frame W.
        """
        p = p_body if self._R_report is None else self._R_report @ p_body
        return p if self._offset_report is None else p + self._offset_report

    def _quantise(self, u: np.ndarray) -> np.ndarray:
        q = np.rint(u / self._tick) * self._tick if self._tick else np.array(u, dtype=float)
        return q if self._held is None else np.where(self._held, u, q)  # a tension is not in ticks

    def _motors(self, t: float) -> np.ndarray:
        step = self._v * (t - self._t0)
        u = self._u0 + np.clip(self._goal - self._u0, -step, step)
        return u if self._held is None else np.where(self._held, self._goal, u)

    def _contraction(self, t: float) -> np.ndarray:
        # Each motor moves monotonically within a segment, so the play output is a clip.
        x = self._r * self._motors(t)
        return np.clip(self._y0, x - self._h, x + self._h)

    def _input(self, t: float) -> np.ndarray:
        return self._ramp(self._p0, self._p1, t)

    def _ramp(self, p0: np.ndarray, p1: np.ndarray, t: float) -> np.ndarray:
        """The equilibrium moving linearly from ``p0`` to ``p1`` over the segment, at ``t``."""
        if self._T <= 0 or t >= self._t0 + self._T:
            return p1
        return p0 + (p1 - p0) * ((t - self._t0) / self._T)

    def _other_markers(self, y: np.ndarray) -> np.ndarray:
        """The equilibrium of every marker but the tip for effective inputs y, flattened (3(K-1),) m."""
        return self.equilibria.markers(y)[1:].ravel()

    def _advance(self, t_s: float) -> None:
        """Integrate the lag modes exactly from the body's time to ``t_s``."""
        t_s = float(t_s)
        if t_s < self._t - 1e-9:
            raise InputError(f"time went backwards: {t_s} s after {self._t} s")
        t_ramp_end = self._t0 + self._T
        while t_s > self._t:
            ramping = self._t < t_ramp_end  # equilibrium moving linearly
            t_b = min(t_s, t_ramp_end) if ramping else t_s
            s = t_b - self._t
            slope = (self._p1 - self._p0) / self._T if ramping else 0.0
            self._z = self._relax(self._z, self._input(self._t), slope, s)
            if self._others:
                slope = (self._m1 - self._m0) / self._T if ramping else 0.0
                self._zm = self._relax(self._zm, self._ramp(self._m0, self._m1, self._t), slope, s)
            self._t = t_b

    def _relax(self, z: np.ndarray, a: np.ndarray, slope, s: float) -> np.ndarray:
        """Lag modes ``z`` (modes, n) after ``s`` seconds of an input ``a + slope t`` (exact)."""
        decay = np.exp(-s / self._tau)[:, None]
        lag = slope * self._tau[:, None]
        return a + slope * s - lag + (z - a + lag) * decay
