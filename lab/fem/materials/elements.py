"""The linear tetrahedra every material law works on: geometry, F(x) and inverted elements.

On a mesh's M tets, the deformation gradient F is linear in the node positions x_W (N, 3)
m: F = x^T G per element, with the shape-function gradients G (M, 4, 3) of the rest
mesh. :class:`TetElements` keeps G, the rest volumes V (M,) m^3 and one sparse matrix B
(9M, 3N) with vec(F) = B vec(x_W), whose transpose scatters element stresses back to the
nodes; the neo-Hookean (:mod:`lab.fem.materials.neo_hookean`) and foam
(:mod:`lab.fem.materials.hyperfoam`) laws extend it. ``_det3``, ``_inv3`` and ``_eigh3``
give determinants, inverses and symmetric eigensystems of (M, 3, 3) stacks, vectorised. A
tet with det F <= 0 is inverted: :class:`InvertedElementError`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from lab.errors import LabRuntimeError
from lab.fem.bodies.mesh import TetMesh

#: Most cyclic Jacobi sweeps for the eigenvalues of C (3 rotations each; they converge
#: quadratically: 3-4 sweeps reach rounding for any C met, the loop stops there).
JACOBI_SWEEPS = 8


@dataclass(frozen=True)
class TetElements:
    """What every material law shares on a mesh: ``tets`` (M, 4), shape-function gradients
    ``G`` (M, 4, 3) (F = x^T G per element) and rest volumes ``V`` (M,) in m^3, with the
    sparse maps between node positions and deformation gradients."""

    tets: np.ndarray
    G: np.ndarray
    V: np.ndarray
    _B: dict = field(default_factory=dict, init=False, repr=False, compare=False)  # see _operators

    @staticmethod
    def geometry(mesh: TetMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(tets, G, V)`` of a mesh."""
        X = mesh.X_W[mesh.tets]
        Dm = np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]], axis=-1)
        Dm_inv = np.linalg.inv(Dm)  # F = Ds Dm^-1
        G = np.concatenate([-Dm_inv.sum(axis=1, keepdims=True), Dm_inv], axis=1)
        return mesh.tets, G, np.linalg.det(Dm) / 6.0

    def _operators(self, n_nodes: int) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """B (9M, 3N) with vec(F) = B vec(x_W), rows ordered (i, j, element) so that each
        F_ij is one contiguous (M,) array (elementwise work on those is ~3x faster than
        on (M, 3, 3) slices), columns (node, axis); and B^T. Built once per node count."""
        if n_nodes not in self._B:
            M = len(self.tets)
            rows = ((3 * np.arange(3)[:, None, None] + np.arange(3)[None, :, None]) * M + np.arange(M)[None, None, :])[
                :, :, :, None
            ]  # (i, j, M, 1)
            cols = 3 * self.tets[None, None, :, :] + np.arange(3)[:, None, None, None]  # (i, 1, M, a)
            vals = self.G.transpose(2, 0, 1)[None, :, :, :]  # G[m, a, j] at (1, j, M, a)
            shape = (3, 3, M, 4)
            B = sp.csr_matrix(
                (
                    np.broadcast_to(vals, shape).ravel(),
                    (np.broadcast_to(rows, shape).ravel(), np.broadcast_to(cols, shape).ravel()),
                ),
                shape=(9 * M, 3 * n_nodes),
            )
            self._B[n_nodes] = (B, B.T.tocsr())
        return self._B[n_nodes]

    def _F(self, x_W) -> np.ndarray:
        """F as (3, 3, M): F[i, j] is the (M,) array of F_ij."""
        x_W = np.asarray(x_W, dtype=float)
        return (self._operators(len(x_W))[0] @ x_W.ravel()).reshape(3, 3, -1)

    def deformation_gradient(self, x_W: np.ndarray) -> np.ndarray:
        """F (M, 3, 3) for node positions ``x_W`` (N, 3)."""
        return np.ascontiguousarray(self._F(x_W).transpose(2, 0, 1))

    def volume_ratio(self, x_W: np.ndarray) -> np.ndarray:
        """det F (M,): each element's volume over its rest volume, at node positions
        ``x_W`` (N, 3) m (negative where an element is inverted)."""
        return _det3(self.deformation_gradient(x_W))


def _det3(F: np.ndarray) -> np.ndarray:
    """Determinants of (M, 3, 3) matrices (closed form; faster than LAPACK for 3x3)."""
    return (
        F[:, 0, 0] * (F[:, 1, 1] * F[:, 2, 2] - F[:, 1, 2] * F[:, 2, 1])
        - F[:, 0, 1] * (F[:, 1, 0] * F[:, 2, 2] - F[:, 1, 2] * F[:, 2, 0])
        + F[:, 0, 2] * (F[:, 1, 0] * F[:, 2, 1] - F[:, 1, 1] * F[:, 2, 0])
    )


def _inv3(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses and determinants of (M, 3, 3) matrices by the adjugate (closed form,
    ~2x faster than with np.cross); an inverted (J <= 0) matrix gives garbage but
    finite entries unless J == 0."""
    a, b, c = F[:, 0, 0], F[:, 0, 1], F[:, 0, 2]
    d, e, f = F[:, 1, 0], F[:, 1, 1], F[:, 1, 2]
    g, h, i = F[:, 2, 0], F[:, 2, 1], F[:, 2, 2]
    adj = np.empty_like(F)
    adj[:, 0, 0], adj[:, 0, 1], adj[:, 0, 2] = e * i - f * h, c * h - b * i, b * f - c * e
    adj[:, 1, 0], adj[:, 1, 1], adj[:, 1, 2] = f * g - d * i, a * i - c * g, c * d - a * f
    adj[:, 2, 0], adj[:, 2, 1], adj[:, 2, 2] = d * h - e * g, b * g - a * h, a * e - b * d
    J = a * adj[:, 0, 0] + b * adj[:, 1, 0] + c * adj[:, 2, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        return adj / J[:, None, None], J


class InvertedElementError(LabRuntimeError):
    """Tetrahedra are inverted (det F <= 0): the law has no finite energy there.

    Parameters
    ----------
    count : int
        How many tets are inverted (kept as ``.count``).
    """

    def __init__(self, count: int):
        super().__init__(f"{count} tetrahedra are inverted (det F <= 0)")
        self.count = count


def _eigh3(C: np.ndarray, vectors: bool = True):
    """Eigenvalues (M, 3) and eigenvectors Q (M, 3, 3) (columns; None unless ``vectors``) of
    symmetric (M, 3, 3) matrices by cyclic Jacobi rotations on (M,) arrays: exact to rounding
    at repeated eigenvalues too, and 2-3x faster than batched LAPACK for 3x3 blocks."""
    a = {(i, j): C[:, i, j].copy() for i in range(3) for j in range(i, 3)}
    one, zero = np.ones(len(C)), np.zeros(len(C))
    V = {(i, j): (one if i == j else zero) for i in range(3) for j in range(3)} if vectors else None
    for _ in range(JACOBI_SWEEPS):
        scale = np.abs(a[0, 0]) + np.abs(a[1, 1]) + np.abs(a[2, 2])
        if np.all(np.abs(a[0, 1]) + np.abs(a[0, 2]) + np.abs(a[1, 2]) <= 1e-18 * scale):
            break
        for p, q, r in ((0, 1, 2), (0, 2, 1), (1, 2, 0)):
            apq = a[p, q]
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                theta = (a[q, q] - a[p, p]) / (2 * apq)
                t = np.where(theta >= 0, 1.0, -1.0) / (np.abs(theta) + np.sqrt(theta * theta + 1))
            t = np.where(apq == 0, 0.0, np.nan_to_num(t, nan=0.0, posinf=0.0, neginf=0.0))
            c = 1 / np.sqrt(t * t + 1)
            s = t * c
            a[p, p], a[q, q], a[p, q] = a[p, p] - t * apq, a[q, q] + t * apq, zero
            rp, rq = (min(r, p), max(r, p)), (min(r, q), max(r, q))
            a[rp], a[rq] = c * a[rp] - s * a[rq], s * a[rp] + c * a[rq]
            if vectors:
                for k in range(3):
                    V[k, p], V[k, q] = c * V[k, p] - s * V[k, q], s * V[k, p] + c * V[k, q]
    w = np.stack([a[0, 0], a[1, 1], a[2, 2]], axis=1)
    return w, (np.stack([np.stack([V[i, j] for j in range(3)], axis=1) for i in range(3)], axis=1) if vectors else None)
