"""Soft IK (Section II-B): inverse kinematics with the FEM in the loop.

The paper's prior, simulation-only method: the same objective ``O(u) = 1/2 |y(u) - y'|^2``
as the learned-model IK (:mod:`lab.control.ik`), but ``y(u)`` is the tip of the static
equilibrium ``x(u) = argmin_x E(x, u)`` (:func:`lab.fem.statics.solve_static`) and
``dy/du`` comes from sensitivity analysis, ``J_tip_u = -S H^-1 d2E/dx du``.

:class:`FEMForwardMap` puts the FEM behind the ``predict_and_jacobian`` interface the
IK solvers use, so Soft IK is simply ``IKSolver(FEMForwardMap(fem), commands)``. Every
solve is warm-started from the nearest earlier equilibrium it has seen (the last one),
moved forward with the first-order predictor ``q0 = q + dq/du (u - u_last)``: along
an IK iteration or a trajectory consecutive commands are close, so each evaluation costs
a few Newton iterations plus one factorisation for the sensitivity.

One property of the FEM map the learned one lacks: a **slack cable has an exactly zero
Jacobian column** (winding it a little changes nothing, its spring is flat for negative
stretch). IK started where a cable is slack cannot "see" that pulling it would help and
may stop at such a flat point; start Soft IK where every cable is taut, e.g. the default
cold start at the centre of the command set. (The smooth network has no such plateaus.)
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.fem.energy import ArmFEM
from lab.fem.statics import StaticSolveError, solve_static


class FEMForwardMap:
    """``u`` (m,) rad -> tip ``p_tip_W`` (3,) m and ``J_tip_u`` (3, m) m/rad by the FEM.

    ``tol_step_m`` is the Newton tolerance passed to :func:`solve_static`. Counters:
    ``n_solves`` (equilibria computed), ``solve_time_s`` (their total time). A static
    solve that fails returns a NaN tip (the IK solvers treat it as a rejected step).
    """

    def __init__(self, fem: ArmFEM, tol_step_m: float = 1e-9):
        self.fem = fem
        self.tol_step_m = float(tol_step_m)
        self.n_solves = 0
        self.solve_time_s = 0.0
        self._last = None  # (u, q, dq_du) of the last converged equilibrium

    @property
    def n_u(self) -> int:
        return self.fem.robot.n_cables

    def reset(self) -> None:
        """Forget the warm start (the next solve starts from the rest shape)."""
        self._last = None

    def predict_and_jacobian(self, u_motor) -> tuple[np.ndarray, np.ndarray]:
        """Tip (3,) m and its Jacobian (3, m) m/rad at the equilibrium for ``u_motor``."""
        u = np.asarray(u_motor, dtype=float)
        if u.shape != (self.n_u,):
            raise InputError(f"expected {self.n_u} motor angles, got shape {u.shape}")
        q0 = None
        if self._last is not None:
            u_last, q_last, dq_du = self._last
            q0 = q_last + dq_du @ (u - u_last)
        sol = self._solve(u, q0)
        if sol is None and q0 is not None:  # the predictor overshot: plain warm start
            sol = self._solve(u, self._last[1])
        if sol is None:
            nan = np.full(3, np.nan)
            return nan, np.full((3, self.n_u), np.nan)
        self._last = (u.copy(), sol.q, sol.dq_du)
        return sol.p_tip_W.copy(), sol.J_tip_u.copy()

    def predict(self, u_motor) -> np.ndarray:
        """Tip (3,) m (or (N, 3) for (N, m) commands, solved in order with warm starts)."""
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
