"""``PneumaticBody``: an emulated as-built arm driven by pressure chambers, in time.

The pneumatic counterpart of :class:`~lab.rig.asbuilt_body.AsBuiltBody` (servos, play and
ticks do not exist here): each chamber is fed by a proportional pressure regulator
(:class:`~lab.asbuilt.fields.ChamberDefects`). A command (Pa, the robot's input units) reaches
the regulator after its dead time; its own reading ``R`` then follows the command
first-order with its time constant, and it delivers ``P = max(gain R + offset, p_min)`` (it
cannot vent below the chamber's minimum, atmosphere by default). ``state`` reports ``R``,
what the regulator's biased sensor says (it reaches the command; the chamber does not).
The as-built FEM (:func:`lab.asbuilt.arm.as_built_fem`: the moved cavities, re-meshed) is
solved once per command, at the pressures finally delivered
(:class:`~lab.asbuilt.equilibria.EquilibriumCache`); between two equilibria every marker
moves in proportion to how far the pressures have gone (each chamber weighted by its
change: exact at both ends, the regulators' own time responses in between). The silicone's
relaxation (``[lag]``, two or three first-order modes) follows that, integrated exactly
over sub-steps of a fifth of the shortest time constant, and the motion capture sees the
markers as it sees a cable arm's (the base's tilt, the frame error).
"""

from __future__ import annotations

import numpy as np

from lab.asbuilt.arm import Defects, DefectsError, EquilibriumCache, as_built_fem, load_defects
from lab.description import RobotDescription
from lab.errors import InputError
from lab.rig.base import Body

__all__ = ["PneumaticBody"]


class PneumaticBody(Body):
    """The as-built pneumatic arm in time (see the module docstring).

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot: pressure chambers, no cables.
    defects : Defects or str or None
        The as-built defects (with ``[[chambers]]``): a :class:`Defects`, a TOML path, or
        None for the robot's shipped default.
    n_rings, n_axial : None
        Refused: a body with chambers is meshed by gmsh at its ``[mesh] size_m``.
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
        self.defects = d = defects if isinstance(defects, Defects) else load_defects(defects, robot)
        if not d.chambers:
            raise DefectsError(f"robot {robot.name!r}: a pneumatic body needs the defects' [[chambers]]")
        self.fem = as_built_fem(robot, d, n_rings=n_rings, n_axial=n_axial)
        self.equilibria = EquilibriumCache(self.fem)
        #: the inputs (the Body interface's name): one pressure regulator per chamber
        self.n_motors = robot.n_inputs
        c = d.chambers
        self._gain = np.array([x.regulator_gain for x in c])
        self._offset = np.array([x.regulator_offset_pa for x in c])
        self._tau_reg = np.array([x.regulator_tau_s for x in c])
        self._dead = np.array([x.regulator_dead_time_s for x in c])
        self._p_min = np.array([ch.bounds[0] for ch in robot.chambers])
        if d.creep_fraction > 0:
            self._w = np.array([1.0 - d.slow_fraction - d.creep_fraction, d.slow_fraction, d.creep_fraction])
            self._tau = np.array([d.tau_fast_s, d.tau_slow_s, d.creep_tau_s])
        else:
            self._w = np.array([1.0 - d.slow_fraction, d.slow_fraction])
            self._tau = np.array([d.tau_fast_s, d.tau_slow_s])
        self._h = min(self._tau_reg.min(), self._tau.min()) / 5  # the longest sub-step, s
        R_tilt, R_frame = d.R_tilt, d.R_frame
        self._R_report = R_tilt if R_frame is None else (R_frame if R_tilt is None else R_frame @ R_tilt)
        self._offset_report = d.frame_offset_m if d.has_frame_offset else None
        #: the observed points (``robot.marker_names``: the tip first)
        self.marker_names = tuple(self.fem.marker_names)
        zero = np.zeros(self.n_motors)
        self._t = 0.0
        self._R, self._S = zero.copy(), zero.copy()  # the regulators' readings and their goals
        self._pending: list[tuple[float, np.ndarray, np.ndarray]] = []  # (time, which chambers, goals)
        P = self.delivered_pa(zero)
        self._P_from, self._P_to = P, P
        self._a_from = self._a_to = self._equilibrium(P)
        self._z = np.stack([self._a_to] * len(self._w))  # lag modes, settled, body frame

    # ---------------------------------------------------------------- Body interface
    def command(self, u_goal_rad: np.ndarray, t_s: float) -> None:
        """New goal pressures from ``t_s`` on (the rig, not the body, enforces the range).

        Parameters
        ----------
        u_goal_rad : numpy.ndarray
            Goal gauge pressures, shape (n_motors,), Pa (the robot's input units; the name
            is the Body interface's).
        t_s : float
            Time (s, body clock) the command is sent; each regulator answers after its dead time.
        """
        goal = np.asarray(u_goal_rad, dtype=float)
        if goal.shape != (self.n_motors,) or not np.all(np.isfinite(goal)):
            raise InputError(f"expected {self.n_motors} finite pressures (Pa), got {goal!r}")
        self._advance(t_s)
        a_now = self._input(self._pressures(self._R))
        P_to = self.delivered_pa(goal)
        self._P_from, self._P_to = self._pressures(self._R), P_to
        self._a_from, self._a_to = a_now, self._equilibrium(P_to)
        for dead in np.unique(self._dead):
            self._pending.append((self._t + float(dead), self._dead == dead, goal.copy()))
        self._pending.sort(key=lambda e: e[0])

    def state(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The regulators' readings and the tip at ``t_s``, after integrating up to then.

        Parameters
        ----------
        t_s : float
            Time (s, body clock); not before the body's time.

        Returns
        -------
        u_present : numpy.ndarray
            The regulators' readings, shape (n_motors,), Pa (they reach the command).
        p_tip_W : numpy.ndarray
            Tip, shape (3,), m, where the motion capture sees it before its noise.
        """
        self._advance(t_s)
        return self._R.copy(), self.report(self._w @ self._z[:, :3])

    def markers(self, t_s: float) -> np.ndarray:
        """Every marker at ``t_s`` where the motion capture sees it before its noise.

        Parameters
        ----------
        t_s : float
            Time (s, body clock); not before the body's time.

        Returns
        -------
        numpy.ndarray
            The markers (``marker_names``, the tip first), shape (K, 3), m, frame W.
        """
        self._advance(t_s)
        return self.report_points((self._w @ self._z).reshape(-1, 3))

    # ---------------------------------------------------------------- quasi-statics
    @property
    def time_s(self) -> float:
        """The body's clock: the latest time it was advanced to, s."""
        return self._t

    def delivered_pa(self, u_pa) -> np.ndarray:
        """The pressures the regulators finally deliver for commands ``u_pa``.

        Parameters
        ----------
        u_pa : array_like
            Commanded gauge pressures, shape (n_motors,), Pa.

        Returns
        -------
        numpy.ndarray
            ``max(gain u + offset, p_min)``, shape (n_motors,), Pa.
        """
        return self._pressures(np.asarray(u_pa, dtype=float))

    def quasi_static_tip(self, u_motor) -> np.ndarray:
        """Noise-free settled tip for the commands ``u_motor`` (Pa): the quasi-static map.

        Parameters
        ----------
        u_motor : array_like
            Commanded pressures, shape (n_motors,), Pa.

        Returns
        -------
        numpy.ndarray
            Settled tip p_tip_W, shape (3,), m, in the motion capture's frame W.
        """
        return self.report(self.equilibria.tip(self.delivered_pa(u_motor)))

    def quasi_static_markers(self, u_motor) -> np.ndarray:
        """Noise-free settled markers for the commands ``u_motor`` (Pa).

        Parameters
        ----------
        u_motor : array_like
            Commanded pressures, shape (n_motors,), Pa.

        Returns
        -------
        numpy.ndarray
            Settled markers (the tip first), shape (K, 3), m, frame W.
        """
        return self.report_points(self.equilibria.markers(self.delivered_pa(u_motor)))

    def report_points(self, points_body: np.ndarray) -> np.ndarray:
        """Where the motion capture reports points of the body frame (as :class:`AsBuiltBody`).

        Parameters
        ----------
        points_body : numpy.ndarray
            Points, shape (P, 3), m, body (FEM) frame.

        Returns
        -------
        numpy.ndarray
            The points, shape (P, 3), m, frame W: ``R_err R_tilt p + frame_offset_m``.
        """
        p = np.asarray(points_body, dtype=float).reshape(-1, 3)
        p = p if self._R_report is None else p @ self._R_report.T
        return p if self._offset_report is None else p + self._offset_report

    def report(self, p_body: np.ndarray) -> np.ndarray:
        """Where the motion capture reports one point of the body frame.

        Parameters
        ----------
        p_body : numpy.ndarray
            A point, shape (3,), m, body frame.

        Returns
        -------
        numpy.ndarray
            The point, shape (3,), m, frame W.
        """
        return self.report_points(p_body)[0]

    # ---------------------------------------------------------------- helpers
    def _pressures(self, R: np.ndarray) -> np.ndarray:
        return np.maximum(self._gain * R + self._offset, self._p_min)

    def _equilibrium(self, P: np.ndarray) -> np.ndarray:
        """Every marker's equilibrium at delivered pressures ``P``, flattened (3K,), body frame."""
        return self.equilibria.markers(P).ravel()

    def _input(self, P: np.ndarray) -> np.ndarray:
        """The markers' quasi-static position at pressures ``P`` between the two equilibria."""
        dP = self._P_to - self._P_from
        total = np.abs(dP).sum()
        if total == 0.0:
            return self._a_to
        s = float(np.sign(dP) @ (P - self._P_from)) / total
        return self._a_from + (self._a_to - self._a_from) * s

    def _advance(self, t_s: float) -> None:
        """Integrate the regulators and the lag modes from the body's time to ``t_s``."""
        t_s = float(t_s)
        if t_s < self._t - 1e-9:
            raise InputError(f"time went backwards: {t_s} s after {self._t} s")
        while t_s > self._t:
            t_event = self._pending[0][0] if self._pending else np.inf
            settled = not self._pending and np.all(self._R == self._S)
            t_b = min(t_s, t_event) if settled else min(t_s, t_event, self._t + self._h)
            s = t_b - self._t
            a0 = self._input(self._pressures(self._R))
            R1 = self._S + (self._R - self._S) * np.exp(-s / self._tau_reg)
            R1 = np.where(np.abs(R1 - self._S) < 1e-9 * (1 + np.abs(self._S)), self._S, R1)  # arrived
            slope = (self._input(self._pressures(R1)) - a0) / s if s > 0 else 0.0
            decay = np.exp(-s / self._tau)[:, None]
            lag = slope * self._tau[:, None]
            self._z = a0 + slope * s - lag + (self._z - a0 + lag) * decay
            self._R, self._t = R1, t_b
            while self._pending and self._pending[0][0] <= self._t + 1e-12:
                _, which, goal = self._pending.pop(0)
                self._S = np.where(which, goal, self._S)
