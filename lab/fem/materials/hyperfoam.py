"""Compressible foam: the Storåkers/Ogden law (Abaqus HYPERFOAM, N = 1) on linear tetrahedra.

    W = (2 mu / alpha^2) [lam1^alpha + lam2^alpha + lam3^alpha - 3 + (1/beta) (J^(-alpha beta) - 1)]

lam_i the principal stretches, J = lam1 lam2 lam3; initial shear modulus mu, bulk modulus
K0 = 2 mu (1/3 + beta), and in uniaxial stress a lateral stretch lam1^-nu exactly, with
nu = beta / (1 + 2 beta) (beta = 0: no Poisson effect). A real foam arm is compressible,
which the neo-Hookean law of :mod:`lab.fem.materials.neo_hookean` only matches at small strain.

sum lam_i^alpha = tr C^(alpha/2), C = F^T F, needs the eigenvalues c_i of C for a real
alpha: Jacobi rotations vectorised over the tets (``_eigh3`` of
:mod:`lab.fem.materials.elements`) give them. The Hessian is the
Daleckii-Krein formula, whose divided differences of c^(alpha/2 - 1) are evaluated in a
form without cancellation, and by their limit where two c_i coincide (``REPEATED_LOG_GAP``),
so that energy, gradient and Hessian are exact and smooth through repeated stretches
(F = I, uniaxial states). :class:`Hyperfoam` has the interface of
:class:`lab.fem.materials.neo_hookean.NeoHookean`; :class:`HyperfoamMaterial` is what ``ArmFEM``'s
``material`` takes. Derivation and measurements: docs/design/fem.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError
from lab.fem.bodies.mesh import TetMesh
from lab.fem.materials.base import register_material
from lab.fem.materials.elements import InvertedElementError, TetElements, _det3, _eigh3, _inv3
from lab.fem.materials.energy_density import EnergyDensityLaw

#: Two principal values c_p, c_q of C count as repeated when |ln c_p - ln c_q| is below
#: this: their divided difference is then the two-term Taylor limit (error ~1e-24 there).
REPEATED_LOG_GAP = 1e-6


def _check_law(mu_pa, alpha, beta) -> None:
    if not np.all(np.isfinite(mu_pa)) or not np.all(np.asarray(mu_pa) > 0):
        raise InputError(f"hyperfoam mu_pa must be finite and > 0, got {np.asarray(mu_pa).ravel()[:5].tolist()}")
    if not (np.isfinite(alpha) and alpha != 0):
        raise InputError(f"hyperfoam alpha must be finite and nonzero, got {alpha!r}")
    if not (np.isfinite(beta) and beta >= 0):
        raise InputError(f"hyperfoam beta must be finite and >= 0 (Poisson ratio in [0, 0.5)), got {beta!r}")


def hyperfoam_matching(youngs_modulus_pa, poisson_ratio, alpha):
    """``(mu_pa, beta)`` of the hyperfoam law with the small-strain stiffness of Young's
    modulus ``youngs_modulus_pa`` (Pa, scalar or (M,)) and Poisson ratio in [0, 0.5):
    mu = E / (2 (1 + nu)) (as :func:`lab.fem.materials.neo_hookean.lame`), beta = nu / (1 - 2 nu).
    For N = 1 the match does not depend on ``alpha`` (nonzero, checked), which sets how
    the foam stiffens at large strain.

    Parameters
    ----------
    youngs_modulus_pa : float or array_like, shape (M,)
        Young's modulus E, Pa.
    poisson_ratio : float
        Poisson ratio nu, in [0, 0.5).
    alpha : float
        The foam's stiffening exponent (nonzero).

    Returns
    -------
    mu_pa : float or ndarray, shape (M,)
        Initial shear modulus, Pa (shaped as ``youngs_modulus_pa``).
    beta : float
        The volumetric exponent (>= 0).
    """
    E, nu = np.asarray(youngs_modulus_pa, float), float(poisson_ratio)
    if not (np.isfinite(nu) and 0 <= nu < 0.5):
        raise InputError(f"hyperfoam matching needs a Poisson ratio in [0, 0.5), got {poisson_ratio!r}")
    if not np.all(np.isfinite(E)) or not np.all(E > 0):
        raise InputError(f"hyperfoam matching needs a finite Young's modulus > 0, got {E.ravel()[:5].tolist()}")
    mu, beta = E / (2 * (1 + nu)), nu / (1 - 2 * nu)
    _check_law(mu, float(alpha), beta)
    return (float(mu) if mu.ndim == 0 else mu), beta


@register_material("hyperfoam")
@dataclass(frozen=True)
class HyperfoamMaterial:
    """The law's parameters, mesh-free: ``mu_pa`` (Pa, scalar or one per tet (M,): the
    as-built softness and gradient scale it per tet), ``alpha`` != 0, ``beta`` >= 0.
    What :class:`lab.fem.model.ArmFEM` takes as ``material``.

    Attributes
    ----------
    mu_pa : float or ndarray, shape (M,)
        Initial shear modulus, Pa.
    alpha : float
        Stiffening exponent (nonzero).
    beta : float
        Volumetric exponent (>= 0; Poisson ratio beta / (1 + 2 beta)).
    """

    mu_pa: float | np.ndarray
    alpha: float
    beta: float

    def __post_init__(self):
        _check_law(self.mu_pa, self.alpha, self.beta)

    @property
    def poisson_ratio(self) -> float:
        """The small-strain Poisson ratio beta / (1 + 2 beta)."""
        return self.beta / (1 + 2 * self.beta)

    def on_mesh(self, mesh: TetMesh) -> Hyperfoam:
        """The law on ``mesh``'s elements.

        Parameters
        ----------
        mesh : TetMesh
            The rest mesh.

        Returns
        -------
        Hyperfoam
            The law with per-tet parameters.
        """
        return Hyperfoam.from_mesh(mesh, self.mu_pa, self.alpha, self.beta)


def _volumetric(s, alpha: float, beta: float):
    """(1/beta)(J^(-alpha beta) - 1) and its first two derivatives in s = ln J (-alpha s at beta = 0)."""
    e = np.exp(-alpha * beta * s)
    v = np.expm1(-alpha * beta * s) / beta if beta > 0 else -alpha * s
    return v, -alpha * e, alpha**2 * beta * e


def _divided_power(lc: np.ndarray, p: float) -> np.ndarray:
    """D (M, 3, 3): D[a, b] = (c_a^p - c_b^p) / (c_a - c_b), and p c_a^(p-1) where c_a = c_b,
    from lc = ln c (M, 3), as exp((p - 1) m) sinh(p x) / sinh(x), m the mean of the two
    logs, x half their difference (no cancellation at any gap)."""
    m = 0.5 * (lc[:, :, None] + lc[:, None, :])
    x = 0.5 * (lc[:, :, None] - lc[:, None, :])
    close = np.abs(x) < 0.5 * REPEATED_LOG_GAP
    safe = np.where(close, 1.0, x)
    ratio = np.where(close, p * (1 + (p * p - 1) * x * x / 6), np.sinh(p * safe) / np.sinh(safe))
    return np.exp((p - 1) * m) * ratio


def hyperfoam_law(F: np.ndarray, mu_pa, alpha: float, beta: float, order: int = 2):
    """Energy density W (M,) in J/m^3, first Piola-Kirchhoff stress P = dW/dF (M, 3, 3) in
    Pa (order >= 1) and tangent A = d2W/dF2 (M, 3, 3, 3, 3) in Pa, A[m, i, j, k, l] =
    dP_ij/dF_kl (order 2), of deformation gradients F (M, 3, 3); ``mu_pa`` scalar or (M,).
    Missing orders are None. Raises :class:`InvertedElementError` where det F <= 0."""
    F = np.asarray(F, float)
    mu = np.broadcast_to(np.asarray(mu_pa, float), F.shape[:1])
    Finv, J = _inv3(F) if order else (None, _det3(F))
    if np.any(J <= 0):
        raise InvertedElementError(int(np.sum(J <= 0)))
    C = np.matmul(F.transpose(0, 2, 1), F)
    c, Q = _eigh3(C, vectors=order > 0)
    if np.any(c <= 0):  # only by rounding, for a tet squashed flat
        raise InvertedElementError(int(np.sum(np.any(c <= 0, axis=1))))
    lc, s, k = np.log(c), np.log(J), 2 * mu / alpha**2
    v, v1, v2 = _volumetric(s, alpha, beta)
    W = k * (np.expm1(0.5 * alpha * lc).sum(axis=1) + v)
    if not order:
        return W, None, None
    FQ = np.matmul(F, Q)  # columns f_p = F q_p
    FinvT = Finv.transpose(0, 2, 1)
    Sd = 0.5 * alpha * np.exp((0.5 * alpha - 1) * lc)  # dW_iso/dC in the eigenbasis, / k
    S = np.matmul(Q * Sd[:, None, :], Q.transpose(0, 2, 1))
    P = (2 * k)[:, None, None] * np.matmul(F, S) + (k * v1)[:, None, None] * FinvT
    if order < 2:
        return W, P, None
    M = len(F)
    D = 0.5 * alpha * _divided_power(lc, 0.5 * alpha - 1)
    # F dS = sum_pq D_pq e_pq <e_pq + e_qp, dF>, e_pq = f_p q_q^T: rows (p, q), columns (i, j)
    E = (FQ.transpose(0, 2, 1)[:, :, None, :, None] * Q.transpose(0, 2, 1)[:, None, :, None, :]).reshape(M, 9, 9)
    Es = E + E.reshape(M, 3, 3, 9).transpose(0, 2, 1, 3).reshape(M, 9, 9)
    A = np.matmul(E.transpose(0, 2, 1), D.reshape(M, 9, 1) * Es).reshape(M, 3, 3, 3, 3)
    A += np.eye(3)[None, :, None, :, None] * S[:, None, :, None, :]  # d_ik S_lj
    A *= (2 * k)[:, None, None, None, None]
    A += (k * v2)[:, None, None, None, None] * FinvT[:, :, :, None, None] * FinvT[:, None, None, :, :]
    A -= (k * v1)[:, None, None, None, None] * FinvT[:, :, None, None, :] * Finv[:, None, :, :, None]
    A9 = A.reshape(M, 9, 9)
    return W, P, (0.5 * (A9 + A9.transpose(0, 2, 1))).reshape(M, 3, 3, 3, 3)


@dataclass(frozen=True)
class Hyperfoam(EnergyDensityLaw):
    """The hyperfoam law on a mesh's elements: ``mu`` (M,) in Pa, ``alpha``, ``beta``. The
    element sums (energy, gradients, Hessians, products) are
    :class:`~lab.fem.materials.energy_density.EnergyDensityLaw`'s.

    Attributes
    ----------
    tets : ndarray of int, shape (M, 4)
        The mesh's tets.
    G : ndarray, shape (M, 4, 3)
        Shape-function gradients, 1/m.
    V : ndarray, shape (M,)
        Rest volumes, m^3.
    mu : ndarray, shape (M,)
        Initial shear modulus, Pa.
    alpha, beta : float
        The law's exponents.
    """

    mu: np.ndarray
    alpha: float
    beta: float

    @classmethod
    def from_mesh(cls, mesh: TetMesh, mu_pa, alpha: float, beta: float) -> Hyperfoam:
        """The law on ``mesh``'s elements.

        Parameters
        ----------
        mesh : TetMesh
            The rest mesh (m, frame W).
        mu_pa : float or array_like, shape (M,)
            Initial shear modulus, Pa, one for all tets or one per tet.
        alpha, beta : float
            The law's exponents (checked: alpha nonzero, beta >= 0).

        Returns
        -------
        Hyperfoam
            The law with per-tet ``mu``.
        """
        _check_law(mu_pa, alpha, beta)
        M = len(mesh.tets)
        mu = np.asarray(mu_pa, float)
        if mu.ndim and mu.shape != (M,):
            raise InputError(f"hyperfoam mu_pa has {mu.size} values for a mesh of {M} tetrahedra")
        tets, G, V = TetElements.geometry(mesh)
        return cls(tets, G, V, np.broadcast_to(mu, (M,)).copy(), float(alpha), float(beta))

    def law(self, x_W: np.ndarray, order: int):
        """``hyperfoam_law`` at node positions ``x_W`` (N, 3).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.
        order : int
            0: energy density only; 1: and stress; 2: and tangent.

        Returns
        -------
        W : ndarray, shape (M,)
            Energy density, J/m^3.
        P : ndarray, shape (M, 3, 3) or None
            First Piola-Kirchhoff stress, Pa.
        A : ndarray, shape (M, 3, 3, 3, 3) or None
            Tangent dP/dF, Pa.
        """
        return hyperfoam_law(self.deformation_gradient(x_W), self.mu, self.alpha, self.beta, order)
