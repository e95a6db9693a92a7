"""A law given by its energy density on linear tetrahedra: the element sums and products.

A hyperelastic law whose energy density W(F) J/m^3, first Piola-Kirchhoff stress
P = dW/dF Pa and tangent A = d2W/dF2 Pa come from one function ``law(x_W, order)``
needs nothing else to be a :class:`~lab.fem.materials.base.MaterialLaw`: the energy is
sum_t V_t W_t, the nodal gradient B^T vec(V P) and the element Hessians K (V A) K^T, K the
map from vec(dF) to the element's dofs (:class:`EnergyDensityLaw`). The Yeoh law of
:mod:`lab.fem.materials.yeoh` and the foam law of :mod:`lab.fem.materials.hyperfoam` are two.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.fem.materials.elements import InvertedElementError, TetElements


@dataclass(frozen=True)
class EnergyDensityLaw(TetElements):
    """The element sums of a density law; a subclass defines ``law(x_W, order)`` returning
    W (M,) J/m^3, P (M, 3, 3) Pa (order >= 1, else None) and A (M, 3, 3, 3, 3) Pa (order 2,
    else None), raising :class:`InvertedElementError` where det F <= 0."""

    def law(self, x_W: np.ndarray, order: int):  # pragma: no cover - abstract
        """Energy density, stress and tangent at ``x_W`` (a subclass's).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.
        order : int
            0: energy density only; 1: and stress; 2: and tangent.

        Returns
        -------
        tuple
            W (M,) J/m^3, P (M, 3, 3) Pa or None, A (M, 3, 3, 3, 3) Pa or None.
        """
        raise NotImplementedError

    def energy(self, x_W: np.ndarray) -> float:
        """Total elastic energy in J; +inf if any element is inverted (J <= 0).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        float
            Energy, J.
        """
        try:
            return float(self.V @ self.law(x_W, 0)[0])
        except InvertedElementError:
            return np.inf

    def _VP(self, x_W):
        W, P, _ = self.law(x_W, 1)
        return W, self.V[:, None, None] * P

    def gradient(self, x_W: np.ndarray) -> np.ndarray:
        """Per-element gradients (M, 4, 3) in N: grad = G (V P)^T.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (M, 4, 3)
            dE_t/dx of each tet's four nodes, N.
        """
        return np.matmul(self.G, self._VP(x_W)[1].transpose(0, 2, 1))

    def nodal_gradient(self, x_W: np.ndarray) -> np.ndarray:
        """dE/dx (N, 3) in N (B^T vec(V P)).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (N, 3)
            dE/dx, N.
        """
        return (self._operators(len(x_W))[1] @ self._VP(x_W)[1].transpose(1, 2, 0).ravel()).reshape(-1, 3)

    def energy_and_gradient(self, x_W: np.ndarray):
        """Total energy in J and dE/dx (N, 3) in N; (inf, None) if any element is inverted.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        energy : float
            J.
        gradient : ndarray, shape (N, 3) or None
            dE/dx, N.
        """
        try:
            W, VP = self._VP(x_W)
        except InvertedElementError:
            return np.inf, None
        return float(self.V @ W), (self._operators(len(x_W))[1] @ VP.transpose(1, 2, 0).ravel()).reshape(-1, 3)

    def _tangent(self, x_W) -> np.ndarray:
        """V A (M, 9, 9), rows (i, j), columns (k, l)."""
        return (self.law(x_W, 2)[2] * self.V[:, None, None, None, None]).reshape(-1, 9, 9)

    def hessian(self, x_W: np.ndarray) -> np.ndarray:
        """Exact per-element Hessians (M, 12, 12) in N/m, dof order (node a, axis i):
        H[a, i, b, k] = V A[i, j, k, l] G[a, j] G[b, l].

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (M, 12, 12)
            d2E_t/dx2 per tet, N/m.
        """
        M = len(self.V)
        K = (np.eye(3)[None, None, :, :, None] * self.G[:, :, None, None, :]).reshape(M, 12, 9)
        return np.matmul(np.matmul(K, self._tangent(x_W)), K.transpose(0, 2, 1))

    def hessian_product(self, x_W: np.ndarray, tangent: np.ndarray | None = None):
        """A function dx (N, 3) -> d2E/dx2 dx (N, 3): exact Hessian products, dP = A : dF.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.
        tangent : ndarray, shape (M, 9, 9), optional
            V A at ``x_W`` if already computed (e.g. by :mod:`lab.fem.kernels`), Pa m^3.

        Returns
        -------
        callable
            dx (N, 3) m -> d2E/dx2 dx (N, 3) N.
        """
        A = self._tangent(x_W) if tangent is None else tangent
        B, B_T = self._operators(len(x_W))
        M = len(A)

        def apply(dx: np.ndarray) -> np.ndarray:
            dF = (B @ np.asarray(dx, float).ravel()).reshape(9, M).T
            dP = np.matmul(A, dF[:, :, None])[:, :, 0]
            return (B_T @ dP.T.ravel()).reshape(-1, 3)

        return apply
