"""A material law's element sums by the compiled kernels, with the interface of the law.

:class:`CompiledLaw` wraps a neo-Hookean, Yeoh or hyperfoam law on a mesh
(:mod:`lab.fem.materials`) and gives its energy, nodal gradient, element Hessians and
Hessian products from its compiled loop (``neo_hookean_sums`` of :mod:`lab.fem.kernels.neo_hookean`,
``yeoh_sums`` or ``hyperfoam_sums`` of :mod:`lab.fem.kernels.elements`), plus
:meth:`CompiledLaw.add_hessian`, which adds every element Hessian straight into the data
array of the global CSR Hessian. Each agrees with the law's own (NumPy) method to rounding
and raises or returns +inf for inverted tets alike.
"""

from __future__ import annotations

import numpy as np

from lab.fem.materials.elements import InvertedElementError
from lab.fem.materials.hyperfoam import Hyperfoam
from lab.fem.materials.neo_hookean import NeoHookean
from lab.fem.materials.yeoh import Yeoh

#: What a loop computes (the ``mode`` of :mod:`lab.fem.kernels.elements`, which imports numba).
ENERGY, GRADIENT, HESSIAN, ELEMENT_HESSIANS, TANGENTS, GRADIENT_AND_HESSIAN = 0, 1, 2, 3, 4, 5


def law_parameters(law):
    """``(kind, prm (M, 4), alpha, beta)`` of a law the kernels know (kind 0: neo-Hookean,
    1: Yeoh, 2: hyperfoam), else None."""
    M = len(law.V)
    prm = np.zeros((M, 4))
    if type(law) is NeoHookean:
        prm[:, 0], prm[:, 1] = law.mu, law.lam
        return 0, prm, 0.0, 0.0
    if type(law) is Yeoh:
        prm[:] = np.column_stack([law.c10, law.c20, law.c30, law.kappa])
        return 1, prm, 0.0, 0.0
    if type(law) is Hyperfoam:
        prm[:, 0] = law.mu
        return 2, prm, float(law.alpha), float(law.beta)
    return None


class CompiledLaw:
    """The element sums of ``law`` by the compiled kernels (imports numba).

    Parameters
    ----------
    law : NeoHookean, Yeoh or Hyperfoam
        The law on a mesh (:func:`law_parameters` says which are known).
    """

    def __init__(self, law):
        from lab.fem.kernels import elements, neo_hookean

        self.law = law
        self.kind, self._prm, self._alpha, self._beta = law_parameters(law)
        #: Whether an energy and gradient cost a large share of a Hessian pass: the hyperfoam's
        #: eigen-decompositions of C (about 0.45 of it; the neo-Hookean's and Yeoh's 0.2).
        self.costly_energy = self.kind == 2
        self._sums = (neo_hookean.neo_hookean_sums, elements.yeoh_sums, elements.hyperfoam_sums)[self.kind]
        self._product = neo_hookean.neo_hookean_product
        self._scatter, self._volume_ratios = elements.scatter_add, elements.volume_ratios
        self._tets = np.ascontiguousarray(law.tets, dtype=np.int64)
        self._G = np.ascontiguousarray(law.G, dtype=float)
        self._V = np.ascontiguousarray(law.V, dtype=float)
        self._none = (np.zeros((0, 3)), np.zeros(0), np.zeros((0, 144), dtype=np.int64), np.zeros((0, 0, 0)))

    def _run_checked(self, mode, x_W, **outputs) -> None:
        """``_run`` for the modes that fill arrays: InvertedElementError if an element is inverted."""
        _, bad = self._run(mode, x_W, **outputs)
        if bad:
            raise InvertedElementError(bad)

    def _run(self, mode, x_W, grad=None, data=None, slots=None, out=None):
        g0, d0, s0, o0 = self._none
        return self._sums(
            mode,
            np.ascontiguousarray(x_W, dtype=float),
            self._tets,
            self._G,
            self._V,
            self._prm,
            self._alpha,
            self._beta,
            g0 if grad is None else grad,
            d0 if data is None else data,
            s0 if slots is None else slots,
            o0 if out is None else out,
        )

    def energy(self, x_W: np.ndarray) -> float:
        """Total elastic energy.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        float
            Energy, J (+inf if an element is inverted).
        """
        e, bad = self._run(ENERGY, x_W)
        return np.inf if bad else float(e)

    def energy_and_gradient(self, x_W: np.ndarray):
        """Energy and nodal gradient in one pass.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        energy : float
            J (+inf if an element is inverted).
        gradient : ndarray, shape (N, 3) or None
            dE/dx, N (None if an element is inverted).
        """
        grad = np.zeros((len(x_W), 3))
        e, bad = self._run(GRADIENT, x_W, grad=grad)
        return (np.inf, None) if bad else (float(e), grad)

    def energy_gradient_hessian(self, x_W: np.ndarray, data: np.ndarray, slots: np.ndarray):
        """Energy, nodal gradient and every element Hessian (added into ``data``) in one pass.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.
        data : ndarray, shape (nnz,)
            The CSR data, N/m, added to in place (:meth:`add_hessian`).
        slots : ndarray of int64, shape (M, 144)
            Each element Hessian entry's slot (-1: skipped).

        Returns
        -------
        energy : float
            J (+inf if an element is inverted; then ``data`` holds a partial sum).
        gradient : ndarray, shape (N, 3) or None
            dE/dx, N (None if an element is inverted).
        """
        grad = np.zeros((len(x_W), 3))
        e, bad = self._run(GRADIENT_AND_HESSIAN, x_W, grad=grad, data=data, slots=slots)
        return (np.inf, None) if bad else (float(e), grad)

    def nodal_gradient(self, x_W: np.ndarray) -> np.ndarray:
        """dE/dx summed at the nodes.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (N, 3)
            dE/dx, N (:class:`InvertedElementError` if an element is inverted).
        """
        grad = np.zeros((len(x_W), 3))
        self._run_checked(GRADIENT, x_W, grad=grad)
        return grad

    def hessian(self, x_W: np.ndarray) -> np.ndarray:
        """Exact element Hessians.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (M, 12, 12)
            d2E_t/dx2 per tet, N/m, dofs (node a, axis i).
        """
        out = np.empty((len(self._V), 12, 12))
        self._run_checked(ELEMENT_HESSIANS, x_W, out=out)
        return out

    def add_hessian(self, x_W: np.ndarray, data: np.ndarray, slots: np.ndarray) -> None:
        """Add every element Hessian into the data of a CSR matrix, tet by tet.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.
        data : ndarray, shape (nnz,)
            The CSR data, N/m, added to in place.
        slots : ndarray of int64, shape (M, 144)
            Where entry (r, c) of tet t's Hessian goes: ``data[slots[t, 12 r + c]]``; -1 to skip.
        """
        self._run_checked(HESSIAN, x_W, data=data, slots=slots)

    def hessian_product(self, x_W: np.ndarray):
        """Exact Hessian products at ``x_W`` (the law's own, from the compiled tangents for a
        law given by its tangent).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        callable
            dx (N, 3) m -> d2E/dx2 dx (N, 3) N.
        """
        if self.kind == 0:  # closed form: one compiled pass over the tets per product
            x = np.ascontiguousarray(x_W, dtype=float)
            bad = int(np.sum(self.volume_ratio(x) <= 0))
            if bad:
                raise InvertedElementError(bad)

            def apply(dx: np.ndarray) -> np.ndarray:
                out = np.zeros((len(x), 3))
                self._product(
                    x,
                    np.ascontiguousarray(dx, dtype=float).reshape(-1, 3),
                    self._tets,
                    self._G,
                    self._V,
                    self._prm,
                    out,
                )
                return out

            return apply
        out = np.empty((len(self._V), 9, 9))
        self._run_checked(TANGENTS, x_W, out=out)
        return self.law.hessian_product(x_W, tangent=out)

    def volume_ratio(self, x_W: np.ndarray) -> np.ndarray:
        """det F of every tet (the law's ``volume_ratio``, compiled).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (M,)
            Each tet's volume over its rest volume (negative where inverted).
        """
        out = np.empty(len(self._V))
        self._volume_ratios(np.ascontiguousarray(x_W, dtype=float), self._tets, self._G, out)
        return out

    def scatter(self, data: np.ndarray, slots: np.ndarray, values: np.ndarray) -> None:
        """``data[slots[i]] += values[i]`` in order, skipping slots of -1.

        Parameters
        ----------
        data : ndarray, shape (nnz,)
            The CSR data, added to in place.
        slots : ndarray of int64, shape (n,)
            Each value's slot (-1: skipped).
        values : ndarray, shape (n,)
            The values.
        """
        self._scatter(data, slots, np.ascontiguousarray(values, dtype=float))
