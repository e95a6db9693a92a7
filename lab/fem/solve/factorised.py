"""A Hessian's factorisation with what the condensed Newton steps need from it.

:class:`Factorised` holds the factorisation of H at an iterate and, for a condensation
(:class:`~lab.fem.actuators.Condensation`: k coordinates e = A^T dq along which an actuator's
law is kept exact), A, S = H^-1 A, C = A^T S and the law's stiffnesses; a condensation not in
H (a volume chamber's rank-k term) is added to its solves by Woodbury. Where the
factorisation is a Cholesky factor H = P^T L L^T P that solves in halves (PARDISO's forward
and backward substitutions, :mod:`lab.fem.solve.linsolve`), C = Y^T Y with Y = L^-1 P A,
the forward half alone, and S is formed only if something asks for it. :class:`Direction`
is H^-1 r kept the same way: a condensed Newton step (:mod:`lab.fem.solve.steps`) needs
A^T d and one d + S v, that is a forward half with k + 1 columns and a backward half with
one, where whole solves of d and S cost k + 1 of each (``docs/fem-cost.md``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["Direction", "Factorised"]


class Factorised:
    """The exact Hessian factorised at an iterate where it is positive definite, with
    what condensed steps need from that point.

    Parameters
    ----------
    lu : object
        The factorisation of H (``solve``; ``forward`` and ``backward`` where its
        ``half_solves``).
    A : ndarray, shape (n_free, k) or None
        The condensation's directions (None without a condensation, as the next three).
    S : ndarray, shape (n_free, k) or None
        H^-1 A; None with ``Y``: then worked out (one backward half) when first asked for.
    C : ndarray, shape (k, k) or None
        A^T H^-1 A.
    K : ndarray, shape (k,) or None
        The law's stiffnesses in H, N/m (zero for a condensation not in the Hessian).
    rank_K : ndarray, shape (k,), optional
        The stiffnesses of a condensation not in H, which :meth:`solve` adds by Woodbury.
    Y : ndarray, shape (n_free, k), optional
        L^-1 P A, the forward half of S (a Cholesky factor H = P^T L L^T P): C = Y^T Y.
    """

    def __init__(self, lu, A, S, C, K, rank_K=None, Y=None):
        self.lu, self.A, self._S, self.C, self.K, self.rank_K, self.Y = lu, A, S, C, K, rank_K, Y

    @property
    def S(self) -> np.ndarray | None:
        """H^-1 A (n_free, k), m per m: Y's backward half, or a whole solve where another
        factorisation came between (the factor is then made again: see ``current``)."""
        if self._S is None and self.Y is not None:
            self._S = self.lu.backward(self.Y) if getattr(self.lu, "current", False) else self.lu.solve(self.A)
        return self._S

    def solve(self, r: np.ndarray) -> np.ndarray:
        """(H + A rank_K A^T)^-1 r: the factorised H, with the rank-k term if any.

        Parameters
        ----------
        r : ndarray, shape (n_free,) or (n_free, m)
            Right-hand side(s), N.

        Returns
        -------
        ndarray, same shape as ``r``
            The solution(s), m.
        """
        z = self.lu.solve(r)
        if self.rank_K is None:
            return z
        D = self.rank_K.reshape((-1,) + (1,) * (np.ndim(z) - 1))
        M = np.eye(len(self.rank_K)) + self.rank_K[:, None] * self.C
        return z - self.S @ np.linalg.solve(M, D * (self.A.T @ z))

    def direction(self, r: np.ndarray) -> Direction:
        """H^-1 r (n_free,) for the condensed step, as its forward half where that is all
        the step needs (:class:`Direction`)."""
        if self.Y is not None:
            return Direction(self, y=self.lu.forward(r))
        return Direction(self, d=self.lu.solve(r))


class Direction:
    """d = H^-1 r (n_free,) of a :class:`Factorised`, kept as d itself or as its forward
    half y = L^-1 P r: the condensed step needs A^T d (= Y^T y) and one d + S v
    (= one backward half of y + Y v), so a Newton step with k condensed coordinates
    costs a forward half with k + 1 columns and a backward half with one, where whole
    solves of S cost k + 1 of each."""

    def __init__(self, fac: Factorised, d=None, y=None):
        self.fac, self._d, self._y = fac, d, y

    @property
    def d(self) -> np.ndarray:
        """H^-1 r, m."""
        if self._d is None:
            self._d = self.fac.lu.backward(self._y)
        return self._d

    def along_A(self) -> np.ndarray:
        """A^T d (k,)."""
        return self.fac.A.T @ self._d if self._y is None else self.fac.Y.T @ self._y

    def plus_S(self, v: np.ndarray) -> np.ndarray:
        """d + S v (n_free,) for v (k,)."""
        return self._d + self.fac.S @ v if self._y is None else self.fac.lu.backward(self._y + self.fac.Y @ v)
