"""The observed half of :class:`lab.fem.model.ArmFEM`: its markers, each linear in the nodes.

A marker (:mod:`lab.fem.bodies`, e.g. the tip) is a fixed weighted sum of a few nodes'
positions, so its position is a linear map of the free coordinates q; the model keeps
that map as a sparse matrix for the tip and for all markers together, which the
sensitivities (dq/du -> dy/du) and the tip Jacobian use.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


class ObservedModel:
    """The markers of :class:`lab.fem.model.ArmFEM` (it sets ``markers`` (name -> marker,
    the tip first), ``tip_nodes``, ``tip_weights`` and the sparse maps ``_S_tip`` and
    ``_S_markers``)."""

    def tip(self, x_W: np.ndarray) -> np.ndarray:
        """The tip marker's position.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.

        Returns
        -------
        ndarray, shape (3,)
            p_tip_W, m.
        """
        return self.tip_weights @ x_W[self.tip_nodes]

    def tip_matrix(self) -> sp.csr_matrix:
        """The tip marker as a linear map of the free coordinates (it is embedded).

        Returns
        -------
        scipy.sparse.csr_matrix, shape (3, n_free)
            S with p_tip = S q + const.
        """
        return self._S_tip

    @property
    def marker_names(self) -> tuple[str, ...]:
        """The observed points, ``"tip"`` first (the body's markers in order)."""
        return tuple(self.markers)

    def observe(self, x_W: np.ndarray) -> np.ndarray:
        """Every marker's position.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.

        Returns
        -------
        ndarray, shape (K, 3)
            The markers of :attr:`marker_names` in frame W, m (row 0 is the tip).
        """
        return np.array([m.position(x_W) for m in self.markers.values()])

    def marker_matrix(self) -> sp.csr_matrix:
        """Every marker as a linear map of the free coordinates (each is linear in the nodes).

        Returns
        -------
        scipy.sparse.csr_matrix, shape (3K, n_free)
            S with ``observe(x).ravel() = S q + const``.
        """
        return self._S_markers
