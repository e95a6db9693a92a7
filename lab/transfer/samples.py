"""The N real samples' equilibria under the FEM at theta, warm-started, for :func:`lab.transfer.calibrate`.

The first pass (:meth:`Samples.first`) solves the samples along a nearest-neighbour walk
from rest, each from its predecessor's equilibrium moved by dq/du; later passes
(:meth:`Samples.solve`) start each sample from the caller's prediction (its last
equilibrium moved by dq/dtheta times the step). A sample that does not converge from its
start is solved from rest, then by continuation in ten steps from rest. The observed points
are the tip (default) or any of the FEM's markers, stacked (x, y, z) per marker.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError, LabRuntimeError
from lab.fem.solve.parameter_layout import ParameterError
from lab.fem.solve.parameters import ParametrisedFEM
from lab.fem.solve.statics import solve_static


def _walk(u: np.ndarray) -> list[int]:
    """A nearest-neighbour walk through the commands (N, m), starting nearest rest."""
    left, order, here = list(range(len(u))), [], np.zeros(u.shape[1])
    while left:
        j = left[int(np.argmin(np.abs(u[left] - here).sum(axis=1)))]
        order.append(j)
        left.remove(j)
        here = u[j]
    return order


class Samples:
    """Equilibria, observed markers (indices ``markers`` into the FEM's, default the tip)
    and sensitivities of every sample at one theta."""

    def __init__(self, pf: ParametrisedFEM, u: np.ndarray, markers=None):
        self.pf, self.u, self.n_solves = pf, u, 0
        self.markers = None if markers is None or list(markers) == [0] else list(markers)
        self.n_y = 3 if self.markers is None else 3 * len(self.markers)

    def _observed(self, sol) -> np.ndarray:
        return sol.p_tip_W if self.markers is None else sol.y_W[self.markers].ravel()

    def solve(self, theta, starts) -> tuple[np.ndarray, np.ndarray] | None:
        """Equilibria q (N, n_free) and observed markers (N, 3K) from ``starts`` (N, n_free);
        None if the parameters leave the model or a sample finds no equilibrium."""
        try:
            fem = self.pf.fem(theta)
        except ParameterError:
            return None
        q, tips = np.empty_like(starts), np.empty((len(self.u), self.n_y))
        for i, (u, q0) in enumerate(zip(self.u, starts)):
            sol = self._solve(fem, u, q0)
            if sol is None:
                return None
            q[i], tips[i] = sol.q, self._observed(sol)
        return q, tips

    def _solve(self, fem, u, q0):
        kw = dict(raise_on_failure=False, check_command=False)
        for start in (q0, None):  # warm, then from rest
            self.n_solves += 1
            try:
                sol = solve_static(fem, u, start, **kw)
            except InputError:  # a prediction with inverted elements: start from rest instead
                continue
            if sol.converged:
                return sol
        prev = solve_static(fem, np.zeros_like(u), **kw)  # continuation for a hard one
        for a in np.linspace(0.1, 1.0, 10):
            self.n_solves += 1
            prev = solve_static(fem, a * u, prev.q, **kw)
            if not prev.converged:
                return None
        return prev

    def first(self, theta):
        """Solve every sample along a nearest-neighbour walk, warm-started by dq/du."""
        fem = self.pf.fem(theta)
        rest = solve_static(fem, np.zeros(self.u.shape[1]), check_command=False)
        q_prev, u_prev, dq_du = rest.q, np.zeros(self.u.shape[1]), None
        q, tips, sens = np.empty((len(self.u), fem.n_free)), np.empty((len(self.u), self.n_y)), [None] * len(self.u)
        for i in _walk(self.u):
            start = q_prev if dq_du is None else q_prev + dq_du @ (self.u[i] - u_prev)
            sol = self._solve(fem, self.u[i], start)
            if sol is None:
                raise LabRuntimeError(f"no equilibrium of the nominal FEM for sample {i}, u = {self.u[i].tolist()} rad")
            q[i], tips[i] = sol.q, self._observed(sol)
            sens[i] = self.pf.sensitivities(theta, sol.q, self.u[i], self.markers)
            q_prev, u_prev, dq_du = sol.q, self.u[i], sens[i][0]
        return q, tips, self._stack(sens)

    def sensitivities(self, theta, q):
        return self._stack([self.pf.sensitivities(theta, qi, ui, self.markers) for qi, ui in zip(q, self.u)])

    @staticmethod
    def _stack(sens):
        """dq/dtheta (N, n_free, p) and J_y_theta (N, 3K, p)."""
        return np.stack([s[1] for s in sens]), np.stack([s[3] for s in sens])
