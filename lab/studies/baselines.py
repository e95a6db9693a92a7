"""Least-squares polynomial baselines of the forward map, for ``python -m lab compare``.

Before crediting a network or a Gaussian process with an accuracy on measured data, the
comparison asks what the simplest models reach: an affine map (``linear``, degree 1) and a
cubic with all cross terms (``poly3``). :func:`fit_poly` scales each input to [-1, 1] by
the training data's range (min-max, so that the monomials are of order one and the least
squares problem is well conditioned), builds every monomial of total degree <= ``degree``
(``C(n_u + degree, degree)`` columns: 84 for 6 motors and degree 3, 455 for 12 inputs)
and solves for the coefficients by least squares (``numpy.linalg.lstsq``; a rank-deficient
design, fewer rows than monomials say, takes the minimum-norm solution).
:class:`PolyModel` gives the prediction (m) and its exact Jacobian (m per input unit), so a
baseline can stand in wherever lab expects a differentiable forward model. Nothing is
saved to disk: the baselines are refitted in a second.
"""

from __future__ import annotations

from itertools import combinations_with_replacement

import numpy as np

from lab.errors import InputError

__all__ = ["MAX_POLY_DEGREE", "PolyModel", "fit_poly", "monomial_exponents"]

#: Highest polynomial degree :func:`fit_poly` takes (the number of columns grows as d^n_u / n_u!).
MAX_POLY_DEGREE = 5


def monomial_exponents(n_u: int, degree: int) -> np.ndarray:
    """Exponents (n_terms, n_u) int of every monomial of total degree 0..``degree`` in
    ``n_u`` variables, the constant first, then by degree."""
    rows = []
    for d in range(degree + 1):
        for combo in combinations_with_replacement(range(n_u), d):
            e = np.zeros(n_u, dtype=int)
            np.add.at(e, list(combo), 1)
            rows.append(e)
    return np.array(rows, dtype=int).reshape(-1, n_u)


class PolyModel:
    """y = sum_t c_t prod_j x_j^e_tj with x = the inputs min-max scaled to [-1, 1].
    ``u_min``, ``u_max`` (n_u,) the training range (a zero range is left unscaled but
    centred); ``exponents`` (n_terms, n_u); ``coef`` (n_terms, n_y) m."""

    kind = "lab.poly"
    has_jacobian = True

    def __init__(self, u_min, u_max, exponents, coef, metadata: dict | None = None):
        self.u_min, self.u_max = np.asarray(u_min, float), np.asarray(u_max, float)
        self.exponents = np.asarray(exponents, dtype=int)
        self.coef = np.asarray(coef, float)
        span = self.u_max - self.u_min
        self.u_gain = np.where(span > 0, 2.0 / np.where(span > 0, span, 1.0), 1.0)
        self.degree = int(self.exponents.sum(axis=1).max()) if len(self.exponents) else 0
        self.metadata = dict(metadata or {})

    n_u = property(lambda self: self.exponents.shape[1])
    n_y = property(lambda self: self.coef.shape[1])

    def __repr__(self) -> str:
        return f"PolyModel(degree {self.degree}, {self.n_u} inputs, {len(self.exponents)} terms)"

    def scale(self, u: np.ndarray) -> np.ndarray:
        """Inputs (N, n_u) mapped to [-1, 1] over the training range."""
        return (u - 0.5 * (self.u_min + self.u_max)) * self.u_gain

    def _batch(self, u) -> tuple[np.ndarray, bool]:
        u = np.asarray(u, float)
        single = u.ndim == 1
        u2 = u[None, :] if single else u
        if u2.ndim != 2 or u2.shape[1] != self.n_u:
            raise InputError(f"expected u of shape (N, {self.n_u}) or ({self.n_u},), got {u.shape}")
        return u2, single

    def _powers(self, x: np.ndarray) -> np.ndarray:
        """x_j^p for p = 0..degree: (N, n_u, degree + 1)."""
        return x[:, :, None] ** np.arange(self.degree + 1)

    def design(self, u) -> np.ndarray:
        """The monomials (N, n_terms) of u (N, n_u)."""
        u2, _ = self._batch(u)
        p = self._powers(self.scale(u2))
        return np.prod(p[:, np.arange(self.n_u), self.exponents], axis=2)

    def predict(self, u) -> np.ndarray:
        """Tips (N, n_y) m for u (N, n_u); (n_y,) for one u (n_u,)."""
        u2, single = self._batch(u)
        y = self.design(u2) @ self.coef
        return y[0] if single else y

    def predict_and_jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """Tips (N, n_y) m and the exact Jacobian dy/du (N, n_y, n_u) (m per input unit);
        (n_y,) and (n_y, n_u) for one u. d/dx_j of prod_k x_k^e_k is
        e_j x_j^(e_j - 1) prod_(k != j) x_k^e_k, times the scaling's gain g_j."""
        u2, single = self._batch(u)
        p = self._powers(self.scale(u2))
        cols = np.arange(self.n_u)
        factors = p[:, cols, self.exponents]  # (N, n_terms, n_u)
        mono = np.prod(factors, axis=2)
        y = mono @ self.coef
        J = np.empty((len(u2), self.n_y, self.n_u))
        for j in range(self.n_u):
            e = self.exponents[:, j]
            d_factor = e * p[:, j, np.maximum(e - 1, 0)]  # d x_j^e / d x_j, 0 where e = 0
            others = np.prod(np.delete(factors, j, axis=2), axis=2)
            J[:, :, j] = (d_factor * others) @ self.coef * self.u_gain[j]
        return (y[0], J[0]) if single else (y, J)

    def jacobian(self, u) -> np.ndarray:
        """dy/du (N, n_y, n_u), or (n_y, n_u) for one u."""
        return self.predict_and_jacobian(u)[1]


def fit_poly(u, y, degree: int) -> PolyModel:
    """Least-squares polynomial of total degree ``degree`` (all cross terms) from inputs
    to tips, the inputs min-max scaled to [-1, 1] by their range in ``u``.

    Parameters
    ----------
    u : array_like, shape (N, n_u)
        Training inputs (motor commands, rad, or any input unit), N >= 2.
    y : array_like, shape (N, n_y)
        Training tips (m), e.g. n_y = 3 for the tip in W.
    degree : int
        Total degree, 1 .. :data:`MAX_POLY_DEGREE`.

    Returns
    -------
    PolyModel
        The fitted model; ``metadata["training"]`` records the number of terms, the rank of
        the design and the training RMS 3-D residual ``train_rms_m`` (m).
    """
    u, y = np.asarray(u, float), np.asarray(y, float)
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or not 1 <= degree <= MAX_POLY_DEGREE:
        raise InputError(f"polynomial degree must be an integer from 1 to {MAX_POLY_DEGREE}, got {degree!r}")
    if u.ndim != 2 or y.ndim != 2 or len(u) != len(y) or len(u) < 2:
        raise InputError(f"expected u (N, n_u) and y (N, n_y) with N >= 2, got {u.shape} and {y.shape}")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
        raise InputError("polynomial fit: u and y must be finite (no NaN or inf)")
    exps = monomial_exponents(u.shape[1], int(degree))
    model = PolyModel(u.min(axis=0), u.max(axis=0), exps, np.zeros((len(exps), y.shape[1])))
    A = model.design(u)
    coef, _, rank, _ = np.linalg.lstsq(A, y, rcond=None)
    model.coef = coef
    resid = np.linalg.norm(A @ coef - y, axis=1)
    model.metadata["training"] = {
        "degree": int(degree),
        "n_terms": len(exps),
        "rank": int(rank),
        "n_samples": len(u),
        "train_rms_m": float(np.sqrt(np.mean(resid * resid))),
    }
    return model
