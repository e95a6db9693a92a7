"""Sparse Hessian assembly on a pattern computed once: where every block entry goes in the CSR data.

The Hessian of :class:`lab.fem.model.ArmFEM` is a sum of dense blocks: one (12, 12) per
tet, and the actuators' (each cable's over the dofs of its eyelets' tets). Their dofs never
change, so :class:`HessianPattern` maps every entry of every block, once, to its slot in
the data array of the CSR matrix (-1 for a clamped dof). The NumPy reference assembly sums
all blocks' entries into their slots with one ``bincount`` (:meth:`HessianPattern.assemble`);
the compiled one (:mod:`lab.fem.kernels`) adds each tet's Hessian straight into the data
through :attr:`HessianPattern.element_slots` and the actuators' blocks after them through
:attr:`HessianPattern.block_slots`, in the same order, so both sum alike.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict

import numpy as np
import scipy.sparse as sp


class HessianPattern:
    """The CSR pattern of a Hessian made of dense blocks, and each block entry's slot.

    Parameters
    ----------
    block_dofs : list of ndarray
        Mesh dofs (int) of each kind of block, shape (n_b, k_b): n_b blocks of k_b dofs (the
        tets' first: (M, 12)).
    dof_to_free : ndarray of int, shape (3N,)
        Free coordinate of each mesh dof, -1 for a clamped one.
    n_free : int
        The number of free coordinates.

    Attributes
    ----------
    indices, indptr : ndarray of int32
        The CSR pattern (sorted, no duplicates) of the (n_free, n_free) Hessian.
    element_slots : ndarray
        Slot (int64) of each entry of each block of the first kind (the tets'), -1 where
        clamped: shape (n_0, k_0 k_0), (M, 144) for the tets.
    block_slots : list of ndarray
        Slots (int64) of the ravelled entries of each further kind of blocks, in order: one
        array of n_b k_b k_b slots per kind.
    """

    def __init__(self, block_dofs: list[np.ndarray], dof_to_free: np.ndarray, n_free: int):
        self.n_free = n_free
        rows, cols = [], []
        for d in block_dofs:
            f = dof_to_free[d]
            rows.append(np.repeat(f, f.shape[1], axis=1).ravel())
            cols.append(np.tile(f, (1, f.shape[1])).ravel())
        sizes = [len(r) for r in rows]
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        self._keep = (rows >= 0) & (cols >= 0)
        key = rows[self._keep] * n_free + cols[self._keep]
        unique, self._slot = np.unique(key, return_inverse=True)
        r = unique // n_free
        self.indices = (unique % n_free).astype(np.int32)
        self.indptr = np.searchsorted(r, np.arange(n_free + 1)).astype(np.int32)
        slots = np.full(len(rows), -1, dtype=np.int64)
        slots[self._keep] = self._slot
        parts = np.split(slots, np.cumsum(sizes)[:-1])
        k0 = block_dofs[0].shape[1]
        self.element_slots = np.ascontiguousarray(parts[0].reshape(-1, k0 * k0))
        self.block_slots = [np.ascontiguousarray(p) for p in parts[1:]]

    #: The patterns :meth:`of` keeps (least recently used dropped), by a digest of their dofs.
    _known: OrderedDict = OrderedDict()
    KEEP = 4

    @classmethod
    def of(cls, block_dofs: list[np.ndarray], dof_to_free: np.ndarray, n_free: int) -> HessianPattern:
        """The pattern of these blocks: a kept one where the same dofs were seen last (no
        copy: a pattern is never changed after it is made), else a new one.

        Parameters
        ----------
        block_dofs, dof_to_free, n_free
            As for the class.

        Returns
        -------
        HessianPattern
            The pattern.
        """
        digest = hashlib.sha1(repr((int(n_free), [np.shape(d) for d in block_dofs])).encode())
        for a in (*block_dofs, dof_to_free):
            digest.update(np.ascontiguousarray(a, dtype=np.int64).tobytes())
        key = digest.hexdigest()
        pattern = cls._known.get(key)
        if pattern is None:
            pattern = cls._known[key] = cls(block_dofs, dof_to_free, n_free)
            while len(cls._known) > cls.KEEP:
                cls._known.popitem(last=False)
        cls._known.move_to_end(key)
        return pattern

    @property
    def nnz(self) -> int:
        """The number of stored entries."""
        return len(self.indices)

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """The CSR matrix with this pattern and ``data``.

        Parameters
        ----------
        data : ndarray, shape (nnz,)
            Its entries, in the pattern's order.

        Returns
        -------
        scipy.sparse.csr_matrix, shape (n_free, n_free)
            The matrix (sharing ``data``).
        """
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n_free, self.n_free))

    def assemble(self, blocks: list[np.ndarray]) -> sp.csr_matrix:
        """The NumPy reference assembly: every block's entries summed into their slots.

        Parameters
        ----------
        blocks : list of ndarray
            Each kind's blocks, ravelled, in the order of the pattern's ``block_dofs``
            (the tets' (M * 144,) first).

        Returns
        -------
        scipy.sparse.csr_matrix, shape (n_free, n_free)
            Their sum.
        """
        values = np.concatenate(blocks)[self._keep]
        return self.matrix(np.bincount(self._slot, weights=values, minlength=self.nnz))
