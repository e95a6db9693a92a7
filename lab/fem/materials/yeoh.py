"""Compressible Yeoh elasticity for silicone (Ecoflex, Dragon Skin) on linear tetrahedra.

    W = C10 (I1bar - 3) + C20 (I1bar - 3)^2 + C30 (I1bar - 3)^3 + (kappa / 2) (J - 1)^2

I1bar = J^(-2/3) tr(F^T F) the isochoric first invariant, J = det F. The volumetric term
is the one Abaqus (``*HYPERELASTIC, YEOH`` with D1 only: (1/D1)(J - 1)^2) and FEBio's
coupled Yeoh use, with kappa = 2 / D1. At small strain the law is linear elasticity with
shear modulus mu = 2 C10 and bulk modulus kappa, so kappa comes either as given or from a
small-strain Poisson ratio nu: kappa = 2 mu (1 + nu) / (3 (1 - 2 nu)), i.e. the neo-Hookean
law of :mod:`lab.fem.materials.neo_hookean` with E = 2 mu (1 + nu) has the same energy to
second order and the same tangent at F = I (:func:`yeoh_matching` gives the parameters).

Stress and tangent are exact and in closed form (:func:`yeoh_law`): with
g = dI1bar/dF = J^(-2/3) (2 F - (2/3) I1 F^-T) and f(x) = sum_i C_i0 x^i,

    P = f'(x) g + kappa (J - 1) J F^-T,
    A = f'' g (x) g + f' d2I1bar/dF2 + kappa J (2J - 1) F^-T (x) F^-T - kappa (J - 1) J F^-T_il F^-T_kj.

:class:`Yeoh` sums them over the elements (:class:`~lab.fem.materials.energy_density.EnergyDensityLaw`);
:class:`YeohMaterial` is what ``ArmFEM``'s ``material`` takes, with C_i0 scalar or one per
tet. An element with J <= 0 is inverted: infinite energy, :class:`InvertedElementError`.
Linear tets lock as nu -> 1/2 (benchmarks/bench_yeoh_locking.py): the Ecoflex arm's sag under
gravity on a 2,501-node mesh falls 5 % from nu = 0.45 to 0.47 and 20 % to 0.49, where the
law's small-strain stiffness E = 4 C10 (1 + nu) accounts for about 1.4 % and 2.8 %; even at
nu = 0.45 the 1,147-node mesh sags 6 % less than the 2,501-node one. Near-incompressible
silicone needs a mixed or F-bar formulation (not here) or a justified compressible nu.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError
from lab.fem.bodies.mesh import TetMesh
from lab.fem.materials.base import register_material
from lab.fem.materials.elements import InvertedElementError, TetElements, _det3, _inv3
from lab.fem.materials.energy_density import EnergyDensityLaw


def yeoh_matching(c10_pa, poisson_ratio):
    """Small-strain moduli of the Yeoh law: ``(mu_pa, kappa_pa, youngs_modulus_pa)`` for
    ``c10_pa`` (Pa, scalar or (M,)) and a Poisson ratio in [0, 0.5): mu = 2 C10,
    kappa = 2 mu (1 + nu) / (3 (1 - 2 nu)), E = 2 mu (1 + nu), the neo-Hookean law's match.

    Parameters
    ----------
    c10_pa : float or array_like, shape (M,)
        C10, Pa (> 0).
    poisson_ratio : float
        Small-strain Poisson ratio nu, in [0, 0.5).

    Returns
    -------
    mu_pa, kappa_pa, youngs_modulus_pa : float or ndarray, shape (M,)
        Shear modulus, bulk modulus and Young's modulus, Pa (shaped as ``c10_pa``).
    """
    c10, nu = np.asarray(c10_pa, float), float(poisson_ratio)
    if not (np.isfinite(nu) and 0 <= nu < 0.5):
        raise InputError(f"yeoh matching needs a Poisson ratio in [0, 0.5), got {poisson_ratio!r}")
    if not np.all(np.isfinite(c10)) or not np.all(c10 > 0):
        raise InputError(f"yeoh matching needs a finite C10 > 0, got {c10.ravel()[:5].tolist()}")
    mu = 2 * c10
    kappa, E = 2 * mu * (1 + nu) / (3 * (1 - 2 * nu)), 2 * mu * (1 + nu)
    return tuple(float(v) if v.ndim == 0 else v for v in (mu, kappa, E))


def yeoh_law(F: np.ndarray, c10, c20, c30, kappa, order: int = 2):
    """Energy density W (M,) J/m^3, first Piola-Kirchhoff stress P (M, 3, 3) Pa (order >= 1)
    and tangent A[m, i, j, k, l] = dP_ij/dF_kl (M, 3, 3, 3, 3) Pa (order 2) of deformation
    gradients F (M, 3, 3); parameters in Pa, scalar or (M,). Missing orders are None.

    Parameters
    ----------
    F : ndarray, shape (M, 3, 3)
        Deformation gradients.
    c10, c20, c30 : float or ndarray, shape (M,)
        The Yeoh coefficients, Pa.
    kappa : float or ndarray, shape (M,)
        Bulk modulus, Pa.
    order : int
        0: energy density only; 1: and stress; 2: and tangent.

    Returns
    -------
    W : ndarray, shape (M,)
        J/m^3.
    P : ndarray, shape (M, 3, 3) or None
        Pa.
    A : ndarray, shape (M, 3, 3, 3, 3) or None
        Pa.
    """
    F = np.asarray(F, float)
    M = len(F)
    c1, c2, c3, k = (np.broadcast_to(np.asarray(c, float), (M,)) for c in (c10, c20, c30, kappa))
    Finv, J = _inv3(F) if order else (None, _det3(F))
    if np.any(J <= 0):
        raise InvertedElementError(int(np.sum(J <= 0)))
    I1 = np.einsum("mij,mij->m", F, F)
    a = J ** (-2.0 / 3.0)
    x = a * I1 - 3
    W = x * (c1 + x * (c2 + x * c3)) + 0.5 * k * (J - 1) ** 2
    if not order:
        return W, None, None
    f1, f2 = c1 + x * (2 * c2 + 3 * c3 * x), 2 * c2 + 6 * c3 * x
    FiT = Finv.transpose(0, 2, 1)
    g = a[:, None, None] * (2 * F - (2.0 / 3.0) * I1[:, None, None] * FiT)
    P = f1[:, None, None] * g + (k * (J - 1) * J)[:, None, None] * FiT
    if order < 2:
        return W, P, None
    e = (slice(None), None, None, None, None)
    outer = lambda X, Y: X[:, :, :, None, None] * Y[:, None, None, :, :]  # noqa: E731  X_ij Y_kl
    cross = FiT[:, :, None, None, :] * Finv[:, None, :, :, None]  # F^-T_il F^-T_kj
    d2I = 2 * np.eye(3)[None, :, None, :, None] * np.eye(3)[None, None, :, None, :]
    d2I = d2I - (4.0 / 3.0) * (outer(F, FiT) + outer(FiT, F)) + (I1 * 4.0 / 9.0)[e] * outer(FiT, FiT)
    d2I = a[e] * (d2I + (I1 * 2.0 / 3.0)[e] * cross)
    A = f2[e] * outer(g, g) + f1[e] * d2I
    A += (k * J * (2 * J - 1))[e] * outer(FiT, FiT) - (k * (J - 1) * J)[e] * cross
    return W, P, A


def _kappa(c10, poisson_ratio, bulk_modulus_pa):
    if (poisson_ratio is None) == (bulk_modulus_pa is None):
        raise InputError("yeoh: give either poisson_ratio or bulk_modulus_pa, not both or neither")
    if bulk_modulus_pa is not None:
        return np.asarray(bulk_modulus_pa, float) + 0 * np.asarray(c10, float)
    return np.asarray(yeoh_matching(c10, poisson_ratio)[1], float)


@register_material("yeoh")
@dataclass(frozen=True)
class YeohMaterial:
    """The Yeoh law's parameters, mesh-free: ``c10_pa`` > 0, ``c20_pa``, ``c30_pa`` (Pa,
    scalar or one per tet (M,)) and the bulk modulus, from ``poisson_ratio`` (small strain,
    [0, 0.5)) or as ``bulk_modulus_pa`` (> 0), exactly one of the two. What
    :class:`lab.fem.model.ArmFEM` takes as ``material``.

    Attributes
    ----------
    c10_pa, c20_pa, c30_pa : float or ndarray, shape (M,)
        The Yeoh coefficients, Pa.
    poisson_ratio : float or None
        Small-strain Poisson ratio (kappa = 4 C10 (1 + nu) / (3 (1 - 2 nu))).
    bulk_modulus_pa : float or ndarray, shape (M,), or None
        Bulk modulus kappa = 2 / D1, Pa.
    """

    c10_pa: float | np.ndarray
    c20_pa: float | np.ndarray = 0.0
    c30_pa: float | np.ndarray = 0.0
    poisson_ratio: float | None = None
    bulk_modulus_pa: float | np.ndarray | None = None

    def __post_init__(self):
        for name in ("c10_pa", "c20_pa", "c30_pa"):
            if not np.all(np.isfinite(np.asarray(getattr(self, name), float))):
                raise InputError(f"yeoh {name} must be finite, got {getattr(self, name)!r}")
        if not np.all(np.asarray(self.c10_pa, float) > 0):
            raise InputError(f"yeoh c10_pa must be > 0, got {self.c10_pa!r}")
        k = self.kappa_pa
        if not (np.all(np.isfinite(k)) and np.all(k > 0)):
            raise InputError(f"yeoh bulk_modulus_pa must be finite and > 0, got {self.bulk_modulus_pa!r}")

    @property
    def kappa_pa(self) -> np.ndarray:
        """The bulk modulus kappa, Pa (scalar or (M,))."""
        return _kappa(self.c10_pa, self.poisson_ratio, self.bulk_modulus_pa)

    def on_mesh(self, mesh: TetMesh) -> Yeoh:
        """The law on ``mesh``'s elements.

        Parameters
        ----------
        mesh : TetMesh
            The rest mesh.

        Returns
        -------
        Yeoh
            The law with per-tet parameters.
        """
        M = len(mesh.tets)
        values = [np.asarray(v, float) for v in (self.c10_pa, self.c20_pa, self.c30_pa, self.kappa_pa)]
        for name, v in zip(("c10_pa", "c20_pa", "c30_pa", "kappa"), values):
            if v.ndim and v.shape != (M,):
                raise InputError(f"yeoh {name} has {v.size} values for a mesh of {M} tetrahedra")
        tets, G, V = TetElements.geometry(mesh)
        return Yeoh(tets, G, V, *(np.broadcast_to(v, (M,)).copy() for v in values))


@dataclass(frozen=True)
class Yeoh(EnergyDensityLaw):
    """The Yeoh law on a mesh's elements: ``c10``, ``c20``, ``c30``, ``kappa`` (M,) in Pa.

    Attributes
    ----------
    tets : ndarray of int, shape (M, 4)
        The mesh's tets.
    G : ndarray, shape (M, 4, 3)
        Shape-function gradients, 1/m.
    V : ndarray, shape (M,)
        Rest volumes, m^3.
    c10, c20, c30, kappa : ndarray, shape (M,)
        The Yeoh coefficients and the bulk modulus, Pa.
    """

    c10: np.ndarray
    c20: np.ndarray
    c30: np.ndarray
    kappa: np.ndarray

    def law(self, x_W: np.ndarray, order: int):
        """:func:`yeoh_law` at node positions ``x_W`` (N, 3).

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
        return yeoh_law(self.deformation_gradient(x_W), self.c10, self.c20, self.c30, self.kappa, order)
