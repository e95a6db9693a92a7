"""Soft IK (Section II-B): inverse kinematics with the FEM in the loop.

:class:`FEMForwardMap` puts the FEM behind the ``predict_and_jacobian`` interface of the IK:
``y(u)`` is the tip of the static equilibrium (:func:`lab.fem.solve.statics.solve_static`) and
``dy/du`` comes from sensitivity analysis, so Soft IK is
``IKSolver(FEMForwardMap(fem), commands)``. Each evaluation is warm-started from the last
equilibrium with a first-order predictor. A slack cable has an exactly zero Jacobian
column, so start Soft IK where every cable is taut (the default centre of the command
set). Details: docs/design/ik.md (Soft IK).
"""

from __future__ import annotations

import numpy as np

from lab.control.markers import marker_rows
from lab.errors import InputError
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import StaticSolveError, solve_static


class FEMForwardMap:
    """``u`` (m,) rad -> tip ``p_tip_W`` (3,) m and ``J_tip_u`` (3, m) m/rad by the FEM.

    Counters: ``n_solves`` (equilibria computed), ``solve_time_s`` (their total time). A
    static solve that fails returns a NaN tip (the IK solvers treat it as a rejected step).

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM.
    tol_step_m : float
        The Newton tolerance (m) passed to :func:`solve_static`.
    markers : tuple of str
        The observed points it predicts (``fem.marker_names``), in order: the tip alone by
        default ((3,) outputs); with others, their ``y_W`` rows ((3M,) outputs).
    """

    def __init__(self, fem: ArmFEM, tol_step_m: float = 1e-9, markers: tuple[str, ...] = ("tip",)):
        self.fem = fem
        self.marker_names = tuple(markers)
        self._rows = None
        if self.marker_names != ("tip",):
            self._rows = marker_rows(tuple(fem.marker_names), self.marker_names, f"robot {fem.robot.name}")
        self.tol_step_m = float(tol_step_m)
        self.n_solves = 0
        self.solve_time_s = 0.0
        self._last = None  # (u, q, dq_du) of the last converged equilibrium

    @property
    def n_u(self) -> int:
        return self.fem.robot.n_inputs

    @property
    def n_y(self) -> int:
        return 3 * len(self.marker_names)

    def reset(self) -> None:
        """Forget the warm start (the next solve starts from the rest shape)."""
        self._last = None

    def predict_and_jacobian(self, u_motor) -> tuple[np.ndarray, np.ndarray]:
        """The tip and its Jacobian at the equilibrium for a command (warm-started).

        Parameters
        ----------
        u_motor : array_like
            The command (m,), each input in its unit (rad or N).

        Returns
        -------
        p_tip_W : numpy.ndarray
            The tip (3,) (or the markers' positions (3M,)), m, frame W; NaN if the static
            solve failed.
        J_tip_u : numpy.ndarray
            Its Jacobian (3, m) (or (3M, m)), m per input unit; NaN if the static solve failed.
        """
        u = np.asarray(u_motor, dtype=float)
        if u.shape != (self.n_u,):
            raise InputError(f"expected {self.n_u} inputs, got shape {u.shape}")
        q0 = None
        if self._last is not None:
            u_last, q_last, dq_du = self._last
            q0 = q_last + dq_du @ (u - u_last)
        sol = self._solve(u, q0)
        if sol is None and q0 is not None:  # the predictor overshot: plain warm start
            sol = self._solve(u, self._last[1])
        if sol is None:
            nan = np.full(self.n_y, np.nan)
            return nan, np.full((self.n_y, self.n_u), np.nan)
        self._last = (u.copy(), sol.q, sol.dq_du)
        if self._rows is None:
            return sol.p_tip_W.copy(), sol.J_tip_u.copy()
        return np.asarray(sol.y_W, float).reshape(-1)[self._rows], np.asarray(sol.J_y_u, float)[self._rows]

    def predict(self, u_motor) -> np.ndarray:
        """The tip at the equilibrium for one or N commands (solved in order with warm starts).

        Parameters
        ----------
        u_motor : array_like
            Command(s) (m,) or (N, m), rad.

        Returns
        -------
        numpy.ndarray
            Tip(s) (3,) or (N, 3), m, frame W.
        """
        u = np.asarray(u_motor, dtype=float)
        if u.ndim == 2:
            return np.array([self.predict_and_jacobian(row)[0] for row in u])
        return self.predict_and_jacobian(u)[0]

    def _solve(self, u, q0):
        try:
            sol = solve_static(self.fem, u, q0, tol_step_m=self.tol_step_m, sensitivity=True, raise_on_failure=False)
        except (ValueError, StaticSolveError):  # e.g. an inverted predictor state
            return None
        self.n_solves += 1
        self.solve_time_s += sol.time_s
        return sol if sol.converged else None
