"""Compressible neo-Hookean elasticity on linear tetrahedra, vectorised over elements.

Energy density (Bonet & Wood):  psi(F) = mu/2 (tr F^T F - 3) - mu ln J + lam/2 (ln J)^2.

F is linear in the node positions (m): one sparse matrix B (9M, 3N) (``TetElements`` of
:mod:`lab.fem.materials.elements`, shared with the foam law of :mod:`lab.fem.materials.hyperfoam`) maps them to every
element's F, kept as (3, 3, M), and B^T scatters the stresses back to the nodes,
dE/dx = B^T vec(V P), with the first Piola-Kirchhoff stress P = mu F - (mu - lam ln J) F^-T.
The element Hessian is exact, in closed form; it is indefinite under strong compression,
so ``project_psd`` clamps negative eigenvalues element by element when the solver
needs a descent direction. A tet with J <= 0 is inverted and has infinite energy.
:meth:`NeoHookean.hessian_product` gives exact Hessian products the same way.

The closed forms per element and why this layout: docs/design/fem.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.fem.bodies.mesh import TetMesh
from lab.fem.materials.base import register_material
from lab.fem.materials.elements import InvertedElementError, TetElements, _det3, _inv3


def lame(youngs_modulus_pa, poisson_ratio):
    """(mu, lam) in Pa from Young's modulus and Poisson ratio (scalars or arrays).

    Parameters
    ----------
    youngs_modulus_pa : float or array_like
        Young's modulus E, Pa.
    poisson_ratio : float or array_like
        Poisson ratio nu, in [0, 0.5).

    Returns
    -------
    mu, lam : ndarray
        Lamé parameters E / (2 (1 + nu)) and E nu / ((1 + nu)(1 - 2 nu)), Pa, broadcast
        from the inputs.
    """
    E, nu = np.asarray(youngs_modulus_pa, float), np.asarray(poisson_ratio, float)
    return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


@register_material("neo-hookean")
@dataclass(frozen=True)
class NeoHookeanMaterial:
    """The neo-Hookean law's parameters, mesh-free: ``youngs_modulus_pa`` (Pa, scalar or
    one per tet (M,)) and ``poisson_ratio``; what :class:`lab.fem.model.ArmFEM` builds from
    the description unless given another ``material``.

    Attributes
    ----------
    youngs_modulus_pa : float or ndarray, shape (M,)
        Young's modulus, Pa.
    poisson_ratio : float
        Poisson ratio, in [0, 0.5).
    """

    youngs_modulus_pa: float | np.ndarray
    poisson_ratio: float

    def on_mesh(self, mesh: TetMesh) -> NeoHookean:
        """The law on ``mesh``'s elements.

        Parameters
        ----------
        mesh : TetMesh
            The rest mesh.

        Returns
        -------
        NeoHookean
            The law with per-tet Lamé parameters.
        """
        return NeoHookean.from_mesh(mesh, self.youngs_modulus_pa, self.poisson_ratio)


@dataclass(frozen=True)
class NeoHookean(TetElements):
    """Neo-Hookean law on a mesh's elements (:class:`TetElements`), with Lamé parameters
    ``mu``, ``lam`` (M,) in Pa.

    Attributes
    ----------
    tets : ndarray of int, shape (M, 4)
        The mesh's tets.
    G : ndarray, shape (M, 4, 3)
        Shape-function gradients, 1/m.
    V : ndarray, shape (M,)
        Rest volumes, m^3.
    mu, lam : ndarray, shape (M,)
        Lamé parameters, Pa.
    """

    mu: np.ndarray
    lam: np.ndarray

    @classmethod
    def from_mesh(cls, mesh: TetMesh, youngs_modulus_pa, poisson_ratio) -> NeoHookean:
        """The law on ``mesh``'s elements.

        Parameters
        ----------
        mesh : TetMesh
            The rest mesh (m, frame W).
        youngs_modulus_pa : float or array_like, shape (M,)
            Young's modulus, Pa, one for all tets or one per tet.
        poisson_ratio : float
            Poisson ratio, in [0, 0.5).

        Returns
        -------
        NeoHookean
            The law with per-tet Lamé parameters.
        """
        tets, G, V = TetElements.geometry(mesh)
        mu, lam = lame(youngs_modulus_pa, poisson_ratio)
        M = len(mesh.tets)
        return cls(tets, G, V, np.broadcast_to(mu, (M,)).copy(), np.broadcast_to(lam, (M,)).copy())

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
        F = self._F(x_W)
        J = (
            F[0, 0] * (F[1, 1] * F[2, 2] - F[1, 2] * F[2, 1])
            - F[0, 1] * (F[1, 0] * F[2, 2] - F[1, 2] * F[2, 0])
            + F[0, 2] * (F[1, 0] * F[2, 1] - F[1, 1] * F[2, 0])
        )
        if np.any(J <= 0):
            return np.inf
        return self._energy(F, np.log(J))

    def _energy(self, F, logJ) -> float:
        I1 = np.einsum("ijm,ijm->m", F, F)
        return float(np.sum(self.V * (0.5 * self.mu * (I1 - 3) - self.mu * logJ + 0.5 * self.lam * logJ**2)))

    def _kinematics(self, x_W):
        """F (M, 3, 3), ln J (M,) and F^-1 (M, 3, 3); raises if an element is inverted."""
        F = self.deformation_gradient(x_W)
        F_inv, J = _inv3(F)
        if np.any(J <= 0):
            raise InvertedElementError(int(np.sum(J <= 0)))
        return F, np.log(J), F_inv

    def _stressed(self, x_W):
        """F (3, 3, M), ln J (M,), the cofactors cof(F) = J F^-T (3, 3, M) and V P (3, 3, M),
        volume times the first Piola-Kirchhoff stress mu F - c F^-T; None if inverted."""
        F = self._F(x_W)
        cof = np.empty_like(F)
        cof[0, 0] = F[1, 1] * F[2, 2] - F[1, 2] * F[2, 1]
        cof[0, 1] = F[1, 2] * F[2, 0] - F[1, 0] * F[2, 2]
        cof[0, 2] = F[1, 0] * F[2, 1] - F[1, 1] * F[2, 0]
        cof[1, 0] = F[0, 2] * F[2, 1] - F[0, 1] * F[2, 2]
        cof[1, 1] = F[0, 0] * F[2, 2] - F[0, 2] * F[2, 0]
        cof[1, 2] = F[0, 1] * F[2, 0] - F[0, 0] * F[2, 1]
        cof[2, 0] = F[0, 1] * F[1, 2] - F[0, 2] * F[1, 1]
        cof[2, 1] = F[0, 2] * F[1, 0] - F[0, 0] * F[1, 2]
        cof[2, 2] = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
        J = F[0, 0] * cof[0, 0] + F[0, 1] * cof[0, 1] + F[0, 2] * cof[0, 2]
        if np.any(J <= 0):
            return None
        logJ = np.log(J)
        VP = (self.V * self.mu) * F - (self.V * (self.mu - self.lam * logJ) / J) * cof
        return F, logJ, cof, J, VP

    def gradient(self, x_W: np.ndarray) -> np.ndarray:
        """Per-element gradients (M, 4, 3) in N: grad = G (V P)^T, the docstring's form.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (M, 4, 3)
            dE_t/dx of each tet's four nodes, N.
        """
        k = self._stressed(x_W)
        if k is None:
            raise InvertedElementError(int(np.sum(_det3(self.deformation_gradient(x_W)) <= 0)))
        return np.matmul(self.G, k[4].transpose(2, 1, 0))

    def nodal_gradient(self, x_W: np.ndarray) -> np.ndarray:
        """dE/dx (N, 3) in N, the element gradients summed at the nodes (B^T vec(V P)).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (N, 3)
            dE/dx, N.
        """
        k = self._stressed(x_W)
        if k is None:
            raise InvertedElementError(int(np.sum(_det3(self.deformation_gradient(x_W)) <= 0)))
        return (self._operators(len(x_W))[1] @ k[4].ravel()).reshape(-1, 3)

    def energy_and_gradient(self, x_W: np.ndarray):
        """Total energy in J and dE/dx (N, 3) in N, computing F once; (inf, None) if any
        element is inverted.

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
        k = self._stressed(x_W)
        if k is None:
            return np.inf, None
        F, logJ, _, _, VP = k
        return self._energy(F, logJ), (self._operators(len(x_W))[1] @ VP.ravel()).reshape(-1, 3)

    def hessian_product(self, x_W: np.ndarray):
        """A function dx (N, 3) -> d2E/dx2 dx (N, 3): exact Hessian products at ``x_W``
        from one evaluation of the kinematics, without the element Hessians:

            dP = mu dF + lam tr(F^-1 dF) F^-T + c (F^-1 dF F^-1)^T,   c = mu - lam ln J

        (per unit volume); each product costs about half a gradient.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        callable
            dx (N, 3) m -> d2E/dx2 dx (N, 3) N.
        """
        k = self._stressed(x_W)
        if k is None:
            raise InvertedElementError(int(np.sum(_det3(self.deformation_gradient(x_W)) <= 0)))
        _, logJ, cof, J, _ = k
        B, B_T = self._operators(len(x_W))
        Fi = np.ascontiguousarray(cof.transpose(1, 0, 2)) / J  # F^-1
        mu, lam, c = self.mu * self.V, self.lam * self.V, (self.mu - self.lam * logJ) * self.V
        M = len(J)

        def apply(dx: np.ndarray) -> np.ndarray:
            dF = (B @ np.asarray(dx, float).ravel()).reshape(3, 3, M)
            G = np.einsum("ijm,jkm->ikm", Fi, dF)  # F^-1 dF
            T = np.einsum("ijm,jkm->ikm", G, Fi)  # F^-1 dF F^-1
            dP = mu * dF + (lam * (G[0, 0] + G[1, 1] + G[2, 2])) * Fi.transpose(1, 0, 2) + c * T.transpose(1, 0, 2)
            return (B_T @ dP.ravel()).reshape(-1, 3)

        return apply

    def hessian(self, x_W: np.ndarray) -> np.ndarray:
        """Exact per-element Hessians (M, 12, 12) in N/m, dof order (node a, axis i).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (M, 12, 12)
            d2E_t/dx2 per tet, N/m.
        """
        F, logJ, F_inv = self._kinematics(x_W)
        A = np.matmul(self.G, F_inv)
        M = len(self.V)
        c, lam, mu = (self.mu - self.lam * logJ) * self.V, self.lam * self.V, self.mu * self.V
        # Broadcast products into one preallocated array: ~3x faster than einsum here.
        H = np.empty((M, 4, 3, 4, 3))
        np.multiply(
            (c[:, None, None] * A)[:, :, None, None, :],  # c A[a,k] A[b,i]
            A.transpose(0, 2, 1)[:, None, :, :, None],
            out=H,
        )
        a = A.reshape(M, 12)
        H_flat = H.reshape(M, 12, 12)
        H_flat += (lam[:, None] * a)[:, :, None] * a[:, None, :]  # lam A[a,i] A[b,k]
        muGG = mu[:, None, None] * np.matmul(self.G, self.G.transpose(0, 2, 1))
        for i in range(3):  # mu (G G^T)[a,b] d_ik
            H[:, :, i, :, i] += muGG
        return H_flat


def project_psd(H: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """Clamp the eigenvalues of each symmetric block (..., n, n) at ``floor``."""
    w, Q = np.linalg.eigh(H)
    return np.einsum("...ij,...j,...kj->...ik", Q, np.maximum(w, floor), Q)
