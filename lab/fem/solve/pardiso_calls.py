"""PARDISO's calls below :mod:`lab.fem.solve.linsolve`: the upper triangle it takes, and one call.

PARDISO factorises a symmetric matrix from its upper triangle in CSR form with 1-based
int32 indices and sorted columns. :class:`UpperPattern` works that out once per sparsity
pattern (a mesh's Hessians share one): each factorisation then only takes the entries
(``take``), and a PARDISO handle knows the pattern it analysed by the pattern's object.
:func:`call` is one call of the MKL routine through ctypes (pypardiso's ``_call_pardiso``,
pinned 0.4.7, without converting the pattern on every call), with the pointers to the arrays
PARDISO keeps between calls made once (:func:`pointer`).
"""

from __future__ import annotations

import ctypes

import numpy as np
import scipy.sparse as sp

__all__ = ["PATTERNS", "UpperPattern", "call", "pointer", "upper_pattern"]


class UpperPattern:
    """The upper triangle of a symmetric CSR sparsity pattern, as PARDISO takes it (sorted
    columns; ``ia``, ``ja`` 1-based int32), worked out once per pattern: each
    factorisation then takes its entries (``take``) instead of ``scipy.sparse.triu``
    (about 2 ms on the three-cable arm's Hessian, half a factorisation); a PARDISO handle
    knows the pattern it analysed by this object.

    Parameters
    ----------
    indptr, indices : ndarray
        The full symmetric pattern's CSR row pointers and column indices (canonical).
    """

    def __init__(self, indptr: np.ndarray, indices: np.ndarray):
        self.key = (indptr.copy(), indices.copy())
        n = len(indptr) - 1
        rows = np.repeat(np.arange(n), np.diff(indptr))
        keep = np.flatnonzero(indices >= rows)
        self.take = keep[np.lexsort((indices[keep], rows[keep]))]
        counts = np.bincount(rows[self.take], minlength=n)
        self.full_rows = bool(np.all(counts > 0))
        self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        self.indices = indices[self.take].astype(np.int32)
        self.ia, self.ja = self.indptr + 1, self.indices + 1

    def fits(self, H: sp.csr_matrix) -> bool:
        """Whether ``H`` has this pattern.

        Parameters
        ----------
        H : scipy.sparse.csr_matrix
            A matrix.

        Returns
        -------
        bool
            Its row pointers and column indices are this pattern's.
        """
        return np.array_equal(H.indptr, self.key[0]) and np.array_equal(H.indices, self.key[1])


#: The patterns met in this process (a few per mesh: the Hessians of its models).
PATTERNS: list[UpperPattern] = []


def upper_pattern(H) -> tuple[UpperPattern, sp.csr_matrix]:
    """The :class:`UpperPattern` of ``H`` (from the cache when known), and ``H`` in CSR form.

    Parameters
    ----------
    H : sparse matrix, shape (n, n)
        A symmetric matrix, any sparse layout.

    Returns
    -------
    pattern : UpperPattern
        Its upper triangle's pattern.
    H : scipy.sparse.csr_matrix
        ``H`` as a float64 CSR matrix in canonical form (``H`` itself when it is one).
    """
    if not (sp.issparse(H) and H.format == "csr" and H.dtype == np.float64):
        H = sp.csr_matrix(H, dtype=float)
    pattern = next((p for p in PATTERNS if p.fits(H)), None)  # a known one is canonical (checking costs 0.3 ms)
    if pattern is None and not H.has_canonical_format:  # duplicate or unsorted entries: summed and sorted (a copy)
        H = H.copy()
        H.sum_duplicates()
        pattern = next((p for p in PATTERNS if p.fits(H)), None)
    if pattern is None:
        pattern = UpperPattern(H.indptr, H.indices)
        PATTERNS.insert(0, pattern)
        del PATTERNS[8:]
    return pattern, H


_I32, _F64 = ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(ctypes.c_double)


def pointer(owner, name: str, kind):
    """A ctypes pointer to the array ``owner.<name>``, made once per array (a few microseconds
    each, eight per call otherwise) and made again if ``owner`` holds another array there.

    Parameters
    ----------
    owner : object
        A PARDISO solver or an :class:`UpperPattern` (the pointer is kept in its ``__dict__``).
    name : str
        The attribute holding the array.
    kind : ctypes pointer type
        The pointer's type.

    Returns
    -------
    ctypes pointer
        To the array's data (it keeps the array alive).
    """
    array, cache = getattr(owner, name), owner.__dict__.setdefault("_lab_pointers", {})
    known = cache.get(name)
    if known is None or known[0] is not array:
        known = cache[name] = (array, array.ctypes.data_as(kind))
    return known[1]


def call(solver, upper: UpperPattern, data: np.ndarray, b: np.ndarray) -> np.ndarray:
    """One PARDISO call (the handle's ``phase``) on the matrix ``(data, upper)``, right-hand
    sides ``b`` (n, k) in Fortran order: pypardiso's ``_call_pardiso`` (pinned 0.4.7) without
    converting the pattern to 1-based int32 on every call.

    Parameters
    ----------
    solver : pypardiso.PyPardisoSolver
        The handle, its ``mtype``, ``phase`` and ``iparm`` set.
    upper : UpperPattern
        The matrix's upper-triangle pattern.
    data : ndarray, shape (nnz_upper,)
        The upper triangle's entries in that pattern's order.
    b : ndarray, shape (n, k)
        Right-hand sides, Fortran order (ignored by the factorisation phases).

    Returns
    -------
    ndarray, shape (n, k)
        PARDISO's output (the solution of a solve phase).
    """
    x = np.zeros_like(b)
    error = ctypes.c_int32(0)
    solver._mkl_pardiso(
        pointer(solver, "pt", ctypes.POINTER(solver._pt_type[0])),
        ctypes.byref(ctypes.c_int32(1)),  # maxfct
        ctypes.byref(ctypes.c_int32(1)),  # mnum
        ctypes.byref(ctypes.c_int32(solver.mtype)),
        ctypes.byref(ctypes.c_int32(solver.phase)),
        ctypes.byref(ctypes.c_int32(len(upper.indptr) - 1)),
        data.ctypes.data_as(_F64),
        pointer(upper, "ia", _I32),
        pointer(upper, "ja", _I32),
        pointer(solver, "perm", _I32),
        ctypes.byref(ctypes.c_int32(b.shape[1])),  # nrhs
        pointer(solver, "iparm", _I32),
        ctypes.byref(ctypes.c_int32(solver.msglvl)),
        b.ctypes.data_as(_F64),
        x.ctypes.data_as(_F64),
        ctypes.byref(error),
    )
    if error.value != 0:
        from pypardiso.pardiso_wrapper import PyPardisoError  # imported already (the solver's)

        raise PyPardisoError(error.value)
    return np.ascontiguousarray(x)
