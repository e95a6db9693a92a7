"""The N real samples' equilibria under the FEM at theta, warm-started, for :func:`lab.transfer.calibrate`.

The first pass (:meth:`Samples.first`) solves the samples along a nearest-neighbour walk
from rest, each from its predecessor's equilibrium moved by dq/du; later passes
(:meth:`Samples.solve`) start each sample from the caller's prediction (its last
equilibrium moved by dq/dtheta times the step). A sample that does not converge from its
start is solved from rest, then by continuation in ten steps from rest. The observed points
are the tip (default) or any of the FEM's markers, stacked (x, y, z) per marker.

With ``reuse`` each sample's sensitivities are taken right after its solve from the solve's
own last factorisation where that is near (:func:`lab.fem.solve.nearby.nearby_sensitivities`:
no new factorisation); the others from a fresh factorisation once every sample is solved, so
that a trial step stopped early pays for none. A pass may stop early: once the samples solved
so far already miss by more than ``limit``, the rest cannot make the step acceptable (or,
asked, once they miss what the linear model expected of them by a ``margin`` of the step's
expected gain).
:func:`first_pass` remembers the last first pass, which calibrations of several robots against
the same nominal description and commands share (in worker processes too:
:func:`remembered_first_pass`, :func:`remember_first_pass`).
"""

from __future__ import annotations

import numpy as np

from lab.data.chunks import nearest_walk
from lab.errors import InputError, LabRuntimeError
from lab.fem.solve.parameter_layout import ParameterError
from lab.fem.solve.parameters import ParametrisedFEM
from lab.fem.solve.statics import solve_static

#: The last first pass: (key, result). Calibrations of many robots against the same nominal
#: description and commands (a recovery study, chapter 05's family) share it.
_FIRST: list = []


def first_pass(samples: Samples, theta, key):
    """:meth:`Samples.first` at ``theta``, remembered for the last ``key`` (anything that
    names the description, mesh, fitted groups, markers and commands exactly): a calibration
    of another robot against the same nominal description repeats no solve. The same arrays
    either way (copies: the caller may keep them).

    Parameters
    ----------
    samples : Samples
        The samples (the pass's solves count in its ``n_solves`` when not remembered).
    theta : numpy.ndarray
        The parameters, shape (p,).
    key : tuple
        What the pass depends on besides ``theta``.

    Returns
    -------
    tuple
        As :meth:`Samples.first`.
    """
    key = (key, np.asarray(theta, float).tobytes(), samples.u.tobytes(), samples.reuse)
    if not _FIRST or _FIRST[0][0] != key:
        _FIRST[:] = [(key, samples.first(theta))]
    q, tips, (dq, J) = _FIRST[0][1]
    return q.copy(), tips.copy(), (dq.copy(), J.copy())


def remembered_first_pass():
    """The first pass :func:`first_pass` remembers, to hand to worker processes
    (:func:`remember_first_pass`): a family's calibrations in workers then repeat none of it.

    Returns
    -------
    tuple or None
        (key, result), or None if no first pass was made in this process.
    """
    return _FIRST[0] if _FIRST else None


def remember_first_pass(entry) -> None:
    """Remember ``entry`` (:func:`remembered_first_pass` of another process) as this process's
    last first pass; None changes nothing. A calibration whose key differs ignores it.

    Parameters
    ----------
    entry : tuple or None
        (key, result).
    """
    if entry is not None:
        _FIRST[:] = [entry]


class Samples:
    """Equilibria, observed markers (indices ``markers`` into the FEM's, default the tip)
    and sensitivities of every sample at one theta. ``reuse``: sensitivities from each
    solve's own factorisation (module docstring). Counts ``n_solves`` (static solves) and
    ``n_factorisations`` (Hessian factorisations, the solves' and the sensitivities')."""

    def __init__(self, pf: ParametrisedFEM, u: np.ndarray, markers=None, *, reuse: bool = False):
        self.pf, self.u, self.n_solves, self.n_factorisations, self.reuse = pf, u, 0, 0, reuse
        self.misfit_m2, self.misfits_m2 = 0.0, np.full(len(u), np.nan)
        self.markers = None if markers is None or list(markers) == [0] else list(markers)
        self.n_y = 3 if self.markers is None else 3 * len(self.markers)

    def _observed(self, sol) -> np.ndarray:
        return sol.p_tip_W if self.markers is None else sol.y_W[self.markers].ravel()

    def solve(self, theta, starts, *, y=None, limit=None, order=None, expected=None, margin=None):
        """Equilibria q (N, n_free) and observed markers (N, 3K) from ``starts`` (N, n_free),
        with ``reuse`` also dq/dtheta (N, n_free, p) and J (N, 3K, p); None if the
        parameters leave the model, a sample finds no equilibrium, or the squared misfit to
        ``y`` (N, 3K) m of the samples solved (in ``order``) exceeds ``limit`` m^2, or exceeds
        what the linear model ``expected`` (N,) m^2 for them by ``margin`` times the gain it
        expected of the whole step (``limit - sum(expected)``); that misfit (so far) is left in
        ``misfit_m2``, each solved sample's in ``misfits_m2`` (N,) (NaN: not solved)."""
        self.misfit_m2, self.misfits_m2 = 0.0, np.full(len(self.u), np.nan)
        try:
            fem = self.pf.fem(theta)
        except ParameterError:
            return None
        q, tips, sens = np.empty_like(starts), np.empty((len(self.u), self.n_y)), [None] * len(self.u)
        misfit = excess = 0.0
        gain = None if expected is None else limit - float(np.sum(expected))  # what the step should win, m^2
        gain = gain if gain is not None and gain > 0 else None
        for i in range(len(self.u)) if order is None else order:
            sol = self._solve(fem, self.u[i], starts[i])
            if sol is None:
                return None
            q[i], tips[i] = sol.q, self._observed(sol)
            if limit is not None:
                self.misfits_m2[i] = float(np.sum((tips[i] - y[i]) ** 2))
                misfit = self.misfit_m2 = misfit + self.misfits_m2[i]
                if misfit >= limit:
                    return None
                if gain is not None:
                    excess += self.misfits_m2[i] - expected[i]
                    if excess >= margin * gain:
                        return None
            if self.reuse:  # from the solve's own factorisation, where it serves
                sens[i] = self._sensitivities(theta, sol.q, self.u[i], sol.factorisation, fresh=False)
        if self.reuse:  # the others from a fresh factorisation, once the pass is whole
            for i in [k for k, got in enumerate(sens) if got is None]:
                sens[i] = self._sensitivities(theta, q[i], self.u[i])
        return (q, tips, *self._stack(sens)) if self.reuse else (q, tips)

    def _solve(self, fem, u, q0):
        kw = dict(raise_on_failure=False, check_command=False, keep_factorisation=self.reuse)
        for start in (q0, None):  # warm, then from rest
            self.n_solves += 1
            try:
                sol = solve_static(fem, u, start, **kw)
            except InputError:  # a prediction with inverted elements: start from rest instead
                continue
            self.n_factorisations += sol.factorizations
            if sol.converged:
                return sol
        prev = solve_static(fem, np.zeros_like(u), **kw)  # continuation for a hard one
        self.n_factorisations += prev.factorizations
        for a in np.linspace(0.1, 1.0, 10):
            self.n_solves += 1
            prev = solve_static(fem, a * u, prev.q, **kw)
            self.n_factorisations += prev.factorizations
            if not prev.converged:
                return None
        return prev

    def _sensitivities(self, theta, q, u, factorisation=None, *, fresh=True):
        """:meth:`ParametrisedFEM.sensitivities` at the equilibrium ``q``, from ``factorisation``
        (its solve's: kept only with ``reuse``, else None) where that serves, else a fresh one
        (None without ``fresh``)."""
        before = self.pf.n_factorisations
        out = self.pf.sensitivities(theta, q, u, self.markers, factorisation=factorisation, fresh=fresh)
        self.n_factorisations += self.pf.n_factorisations - before
        return out

    def first(self, theta):
        """Solve every sample along a nearest-neighbour walk, warm-started by dq/du."""
        fem = self.pf.fem(theta)
        rest = solve_static(fem, np.zeros(self.u.shape[1]), check_command=False)
        self.n_factorisations += rest.factorizations
        q_prev, u_prev, dq_du = rest.q, np.zeros(self.u.shape[1]), None
        q, tips, sens = np.empty((len(self.u), fem.n_free)), np.empty((len(self.u), self.n_y)), [None] * len(self.u)
        for i in nearest_walk(self.u):
            start = q_prev if dq_du is None else q_prev + dq_du @ (self.u[i] - u_prev)
            sol = self._solve(fem, self.u[i], start)
            if sol is None:
                raise LabRuntimeError(f"no equilibrium of the nominal FEM for sample {i}, u = {self.u[i].tolist()} rad")
            q[i], tips[i] = sol.q, self._observed(sol)
            sens[i] = self._sensitivities(theta, sol.q, self.u[i], sol.factorisation)
            q_prev, u_prev, dq_du = sol.q, self.u[i], sens[i][0]
        return q, tips, self._stack(sens)

    def sensitivities(self, theta, q):
        """dq/dtheta (N, n_free, p) and J (N, 3K, p) at the equilibria q (N, n_free), each
        from a fresh factorisation."""
        before = self.pf.n_factorisations
        out = [self.pf.sensitivities(theta, qi, ui, self.markers) for qi, ui in zip(q, self.u)]
        self.n_factorisations += self.pf.n_factorisations - before
        return self._stack(out)

    @staticmethod
    def _stack(sens):
        """dq/dtheta (N, n_free, p) and J (N, 3K, p)."""
        return np.stack([s[1] for s in sens]), np.stack([s[3] for s in sens])
