"""Warm starts along a walk of commands: predict the next equilibrium from solved ones.

A walk (:func:`lab.data.simulation.solve_chunk`) solves commands one after the other, each a
small step from solved ones. :class:`WalkPredictor` keeps every equilibrium of the walk
(u, q, dq/du, which cables are taut) and offers predictions for a new command ``u`` from its
nearest solved neighbours ``u - s``: linear, Hermite (the cubic through two solved points),
and either of those corrected by the error the same prediction made one row back.
:meth:`WalkPredictor.ranked` orders them by energy E(q, u), lowest first, except that those
where a cable changes state although its motor did not move come last. The Hermite and
corrected predictions need dq/du refined along the walk (``refine_du`` of
:func:`lab.fem.solve.statics.solve_static`). Everything depends only on the walk, so a walk gives
the same numbers wherever it runs.

Each prediction, its accuracy on the grid and the ranking rule: docs/design/fem.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.fem.model import ArmFEM
from lab.fem.solve.statics import StaticSolution


@dataclass(frozen=True)
class _Solved:
    u: np.ndarray  # (m,) rad
    q: np.ndarray  # (n_free,) m
    dq_du: np.ndarray  # (n_free, m) m/rad
    taut: tuple  # which inputs' actuators are engaged (a cable pulls, tension > 0)


def _key(u) -> tuple:
    """Commands as integers of 1e-9 rad, so u - s finds u_p again despite rounding."""
    return tuple(np.rint(np.asarray(u) * 1e9).astype(np.int64).tolist())


def _hermite(p0, p1, m0, m1):
    """Cubic Hermite through (t=0: p0, m0), (t=1: p1, m1), evaluated at t=2."""
    return 5 * p0 - 4 * p1 + 2 * m0 + 4 * m1


class WalkPredictor:
    """Solved equilibria of one walk on ``fem`` and predictions from them.

    Parameters
    ----------
    fem : ArmFEM
        The model the walk solves (its energy ranks the predictions, its
        :meth:`~lab.fem.model.ArmFEM.input_states` tell which actuators are engaged).
    """

    def __init__(self, fem: ArmFEM):
        self.fem = fem
        self._solved: dict[tuple, _Solved] = {}
        self.last: _Solved | None = None

    def add(self, sol: StaticSolution) -> None:
        """Keep a converged solution for later predictions.

        Parameters
        ----------
        sol : StaticSolution
            A converged solution with ``dq_du``.

        Returns
        -------
        None
        """
        self.last = _Solved(np.asarray(sol.u_motor, float), sol.q, sol.dq_du, self._taut(sol.q, sol.u_motor))
        self._solved[_key(sol.u_motor)] = self.last

    def _taut(self, q, u) -> tuple:
        """Which inputs' actuators are engaged (cables: pull, tension > 0) at ``q`` for inputs ``u``."""
        return self.fem.input_states(q, u)

    def _get(self, u) -> _Solved | None:
        return self._solved.get(_key(u))

    def _predict(self, u, s, kind):
        """Linear or Hermite prediction for ``u`` along the step ``s`` and the solved
        points it comes from, or None if those are not all solved."""
        p1 = self._get(u - s)
        if p1 is None:
            return None
        step = u - p1.u
        if kind == "linear":
            return p1.q + p1.dq_du @ step, [p1]
        p0 = self._get(u - 2 * s)
        if p0 is None:
            return None
        return _hermite(p0.q, p1.q, p0.dq_du @ step, p1.dq_du @ step), [p0, p1]

    def candidates(self, u_motor) -> list[tuple[str, np.ndarray, list]]:
        """Named predictions for ``u_motor`` from its nearest solved neighbours.

        Parameters
        ----------
        u_motor : array_like, shape (n_inputs,)
            The next inputs.

        Returns
        -------
        list of (str, ndarray, list)
            Each prediction's name, q0 (n_free,) m, and the solved points whose actuator
            states (cables taut or slack) it should carry over.
        """
        u = np.asarray(u_motor, float)
        if not self._solved:
            return []
        pts = list(self._solved.values())
        dist = np.array([np.linalg.norm(u - p.u) for p in pts])
        near = [u - p.u for p, d in zip(pts, dist) if d <= dist.min() * (1 + 1e-9)]
        walk = None if self.last is None else u - self.last.u
        if walk is not None and not any(np.allclose(s, walk, atol=1e-12) for s in near):
            near.append(walk)
        out = []
        for s in near:
            if not np.any(s):
                out.append(("solved", self._get(u).q.copy(), [self._get(u)]))
                continue
            along = walk is not None and np.allclose(s, walk, atol=1e-12)
            for kind in ("linear", "hermite"):
                base = self._predict(u, s, kind)
                if base is None:
                    continue
                corrected = []
                if along or kind == "linear":
                    for t in near:
                        if abs(abs(s @ t) - np.linalg.norm(s) * np.linalg.norm(t)) <= 1e-9 * (s @ s):
                            continue  # t parallel to s (or 0): no parallelogram
                        row, start, back = self._get(u - t), self._get(u - s), self._get(u - s - t)
                        if row is None or back is None or start.taut != back.taut:
                            continue
                        other = self._predict(row.u, s, kind)
                        if other is not None:  # carries the row's cable states over
                            corrected.append((kind + " corrected", base[0] + row.q - other[0], [row]))
                # Across the walk (from rows solved before), plain linear and corrected
                # Hermite predictions were never or rarely the best on the 308-point grid.
                if along or kind == "hermite" or not corrected:
                    out.append((kind, *base))
                out += corrected
        return out

    def ranked(self, u_motor) -> list[tuple[str, np.ndarray]]:
        """The candidates without inverted elements, plausible ones first, each group by
        energy, lowest first. Implausible: an input that is the same as at a point the
        prediction comes from has its actuator engaged there and not in the prediction or
        the reverse (a cable taut and slack: such predictions were where the exact
        Hessian is indefinite).

        Parameters
        ----------
        u_motor : array_like, shape (n_inputs,)
            The next inputs.

        Returns
        -------
        list of (str, ndarray)
            Each prediction's name and q0 (n_free,) m, best first.
        """
        u = np.asarray(u_motor, float)
        cands = self.candidates(u)
        energies = np.array([self.fem.energy(q, u) for _, q, _ in cands])
        implausible = []
        for (_, q, refs), energy in zip(cands, energies):
            taut = self._taut(q, u) if np.isfinite(energy) else None
            implausible.append(
                taut is None
                or any(t != pt for p in refs for t, pt, du in zip(taut, p.taut, u - p.u) if abs(du) <= 1e-12)
            )
        order = np.lexsort((energies, implausible))
        return [cands[i][:2] for i in order if np.isfinite(energies[i])]
