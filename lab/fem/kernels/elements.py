"""The element sums of every material law, each law one compiled loop over the tets (numba).

Each law's loop (:func:`neo_hookean_sums`, :func:`yeoh_sums`, :func:`hyperfoam_sums`, compiled
separately, when first used) visits each tet once: F from its four nodes, the law's energy density,
stress or tangent at F (neo-Hookean and Yeoh here, the foam law in :mod:`.foam`), and then,
by ``mode``, the energy alone, the energy and the nodal gradient, the element Hessian added
straight into the CSR data of the global Hessian through each entry's precomputed slot, the
dense element Hessians, or the tangents. The Hessian of a law given by its tangent is
H[(a, i), (b, k)] = sum_jl G[a, j] V A[(i, j), (k, l)] G[b, l] (two small contractions);
the neo-Hookean one is the closed form of :meth:`lab.fem.materials.NeoHookean.hessian`.
Importing this module imports numba (:func:`lab.fem.kernels.backend.jit`).
"""

from __future__ import annotations

import math

import numpy as np

from lab.fem.kernels.backend import jit
from lab.fem.kernels.foam import foam_element

#: The laws, by number (``kind``).
NEO_HOOKEAN, YEOH, HYPERFOAM = 0, 1, 2
#: What :func:`element_sums` computes (``mode``).
ENERGY, GRADIENT, HESSIAN, ELEMENT_HESSIANS, TANGENTS = 0, 1, 2, 3, 4


@jit
def _deformation(x, tets, G, e, F):
    """F (3, 3) of tet ``e``: F_ij = sum_a x[tets[e, a], i] G[e, a, j]."""
    for i in range(3):
        for j in range(3):
            s = 0.0
            for a in range(4):
                s += x[tets[e, a], i] * G[e, a, j]
            F[i, j] = s


@jit
def _inverse(F, Fi):
    """det F; and F^-1 into Fi where det F > 0 (the adjugate over the determinant)."""
    a, b, c = F[0, 0], F[0, 1], F[0, 2]
    d, e, f = F[1, 0], F[1, 1], F[1, 2]
    g, h, i = F[2, 0], F[2, 1], F[2, 2]
    c00, c01, c02 = e * i - f * h, c * h - b * i, b * f - c * e
    c10, c11, c12 = f * g - d * i, a * i - c * g, c * d - a * f
    c20, c21, c22 = d * h - e * g, b * g - a * h, a * e - b * d
    J = a * c00 + b * c10 + c * c20
    if J > 0:
        Fi[0, 0], Fi[0, 1], Fi[0, 2] = c00 / J, c01 / J, c02 / J
        Fi[1, 0], Fi[1, 1], Fi[1, 2] = c10 / J, c11 / J, c12 / J
        Fi[2, 0], Fi[2, 1], Fi[2, 2] = c20 / J, c21 / J, c22 / J
    return J


@jit
def _neo_hookean(F, Fi, J, mu, lam, order, P):
    """Energy density of the neo-Hookean law; with ``order`` >= 1 the stress into P."""
    logJ = math.log(J)
    I1 = 0.0
    for i in range(3):
        for j in range(3):
            I1 += F[i, j] * F[i, j]
    if order >= 1:
        c = mu - lam * logJ
        for i in range(3):
            for j in range(3):
                P[i, j] = mu * F[i, j] - c * Fi[j, i]
    return 0.5 * mu * (I1 - 3) - mu * logJ + 0.5 * lam * logJ * logJ


@jit
def _neo_hookean_hessian(G, e, Fi, J, mu, lam, Ag, H):
    """The closed-form element Hessian (144,) of the neo-Hookean law (V in mu, lam):
    c Ag[a, k] Ag[b, i] + lam Ag[a, i] Ag[b, k] + mu (G G^T)[a, b] d_ik, Ag = G F^-1."""
    c = mu - lam * math.log(J)
    for a in range(4):
        for k in range(3):
            Ag[a, k] = G[e, a, 0] * Fi[0, k] + G[e, a, 1] * Fi[1, k] + G[e, a, 2] * Fi[2, k]
    for a in range(4):
        for b in range(4):
            gg = mu * (G[e, a, 0] * G[e, b, 0] + G[e, a, 1] * G[e, b, 1] + G[e, a, 2] * G[e, b, 2])
            for i in range(3):
                for k in range(3):
                    h = c * Ag[a, k] * Ag[b, i] + lam * Ag[a, i] * Ag[b, k]
                    if i == k:
                        h += gg
                    H[12 * (3 * a + i) + 3 * b + k] = h


@jit
def _yeoh(F, Fi, J, c1, c2, c3, kappa, order, P, A):
    """Energy density of the Yeoh law (``lab.fem.materials.yeoh.yeoh_law``); with ``order`` >= 1
    the stress into P (3, 3), with order 2 the tangent into A (9, 9)."""
    I1 = 0.0
    for i in range(3):
        for j in range(3):
            I1 += F[i, j] * F[i, j]
    a = J ** (-2.0 / 3.0)
    x = a * I1 - 3
    W = x * (c1 + x * (c2 + x * c3)) + 0.5 * kappa * (J - 1) ** 2
    if order == 0:
        return W
    f1, f2 = c1 + x * (2 * c2 + 3 * c3 * x), 2 * c2 + 6 * c3 * x
    vol = kappa * (J - 1) * J
    for i in range(3):
        for j in range(3):
            g = a * (2 * F[i, j] - (2.0 / 3.0) * I1 * Fi[j, i])
            P[i, j] = f1 * g + vol * Fi[j, i]
    if order < 2:
        return W
    for i in range(3):
        for j in range(3):
            gij = a * (2 * F[i, j] - (2.0 / 3.0) * I1 * Fi[j, i])
            for k in range(3):
                for l in range(3):
                    gkl = a * (2 * F[k, l] - (2.0 / 3.0) * I1 * Fi[l, k])
                    cross = Fi[l, i] * Fi[j, k]  # F^-T_il F^-T_kj
                    outer = Fi[j, i] * Fi[l, k]  # F^-T_ij F^-T_kl
                    d2I = 2.0 if (i == k and j == l) else 0.0
                    d2I = d2I - (4.0 / 3.0) * (F[i, j] * Fi[l, k] + Fi[j, i] * F[k, l]) + (I1 * 4.0 / 9.0) * outer
                    d2I = a * (d2I + (I1 * 2.0 / 3.0) * cross)
                    A[3 * i + j, 3 * k + l] = f2 * gij * gkl + f1 * d2I + kappa * J * (2 * J - 1) * outer - vol * cross
    return W


@jit
def _contract(G, e, Ve, A, T, H):
    """H (144,) = K (Ve A) K^T for the tangent A (9, 9), K[(a, i), (k, l)] = d_ik G[e, a, l];
    T (9, 12) is scratch."""
    for r in range(9):
        for b in range(4):
            for k in range(3):
                T[r, 3 * b + k] = Ve * (
                    A[r, 3 * k] * G[e, b, 0] + A[r, 3 * k + 1] * G[e, b, 1] + A[r, 3 * k + 2] * G[e, b, 2]
                )
    for a in range(4):
        for i in range(3):
            for c in range(12):
                H[12 * (3 * a + i) + c] = (
                    G[e, a, 0] * T[3 * i, c] + G[e, a, 1] * T[3 * i + 1, c] + G[e, a, 2] * T[3 * i + 2, c]
                )


@jit
def _emit(mode, e, Ve, tets, G, P, A, H, grad, data, slots, out):
    """Tet e's share by ``mode``: V G P^T into ``grad``, V A into ``out``, or its Hessian H
    (144,) into ``data`` at ``slots[e]`` or into ``out[e]``."""
    if mode == GRADIENT:
        for a in range(4):
            n = tets[e, a]
            for i in range(3):
                grad[n, i] += Ve * (G[e, a, 0] * P[i, 0] + G[e, a, 1] * P[i, 1] + G[e, a, 2] * P[i, 2])
    elif mode == TANGENTS:
        for r in range(9):
            for t in range(9):
                out[e, r, t] = Ve * A[r, t]
    elif mode == HESSIAN:
        for r in range(144):
            s = slots[e, r]
            if s >= 0:
                data[s] += H[r]
    elif mode == ELEMENT_HESSIANS:
        for r in range(12):
            for t in range(12):
                out[e, r, t] = H[12 * r + t]


@jit
def neo_hookean_sums(mode, x, tets, G, V, prm, alpha, beta, grad, data, slots, out):
    """One pass over the tets of the neo-Hookean law (prm[:, :2] = mu, lam in Pa).

    ``mode``: ENERGY; GRADIENT (dE/dx also added into ``grad`` (N, 3)); HESSIAN (element
    Hessians added into ``data`` at ``slots`` (M, 144), -1: a clamped dof, skipped);
    ELEMENT_HESSIANS (into ``out`` (M, 12, 12)); TANGENTS (V A into ``out`` (M, 9, 9), not
    for this law). Node positions ``x`` (N, 3) m, ``tets`` (M, 4), shape-function gradients
    ``G`` (M, 4, 3), rest volumes ``V`` (M,), per-tet parameters ``prm`` (M, 4) and the
    foam's exponents ``alpha``, ``beta`` (unused here). Returns (energy J, number of
    inverted tets); nothing is added for an inverted tet."""
    F, Fi, P, A, H, Ag = (
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty((1, 1)),
        np.empty(144),
        np.empty((4, 3)),
    )
    energy, bad = 0.0, 0
    for e in range(tets.shape[0]):
        _deformation(x, tets, G, e, F)
        J = _inverse(F, Fi)
        if not J > 0:
            bad += 1
            continue
        Ve = V[e]
        energy += Ve * _neo_hookean(F, Fi, J, prm[e, 0], prm[e, 1], 1 if mode == GRADIENT else 0, P)
        if mode == HESSIAN or mode == ELEMENT_HESSIANS:
            _neo_hookean_hessian(G, e, Fi, J, Ve * prm[e, 0], Ve * prm[e, 1], Ag, H)
        _emit(mode, e, Ve, tets, G, P, A, H, grad, data, slots, out)
    return energy, bad


@jit
def yeoh_sums(mode, x, tets, G, V, prm, alpha, beta, grad, data, slots, out):
    """:func:`neo_hookean_sums` for the Yeoh law (prm = c10, c20, c30, kappa in Pa)."""
    F, Fi, P, A, T, H = (
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty((9, 9)),
        np.empty((9, 12)),
        np.empty(144),
    )
    order = 0 if mode == ENERGY else (1 if mode == GRADIENT else 2)
    energy, bad = 0.0, 0
    for e in range(tets.shape[0]):
        _deformation(x, tets, G, e, F)
        J = _inverse(F, Fi)
        if not J > 0:
            bad += 1
            continue
        Ve = V[e]
        energy += Ve * _yeoh(F, Fi, J, prm[e, 0], prm[e, 1], prm[e, 2], prm[e, 3], order, P, A)
        if mode == HESSIAN or mode == ELEMENT_HESSIANS:
            _contract(G, e, Ve, A, T, H)
        _emit(mode, e, Ve, tets, G, P, A, H, grad, data, slots, out)
    return energy, bad


@jit
def hyperfoam_sums(mode, x, tets, G, V, prm, alpha, beta, grad, data, slots, out):
    """:func:`neo_hookean_sums` for the hyperfoam law (prm[:, 0] = mu in Pa; ``alpha``, ``beta``)."""
    F, Fi, P, A, T, H = (
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty((9, 9)),
        np.empty((9, 12)),
        np.empty(144),
    )
    w = np.empty((8, 9, 9))
    order = 0 if mode == ENERGY else (1 if mode == GRADIENT else 2)
    energy, bad = 0.0, 0
    for e in range(tets.shape[0]):
        _deformation(x, tets, G, e, F)
        J = _inverse(F, Fi)
        W = foam_element(F, Fi, J, prm[e, 0], alpha, beta, order, P, A, w) if J > 0 else math.nan
        if math.isnan(W):  # inverted, or squashed flat (an eigenvalue of C not positive)
            bad += 1
            continue
        Ve = V[e]
        energy += Ve * W
        if mode == HESSIAN or mode == ELEMENT_HESSIANS:
            _contract(G, e, Ve, A, T, H)
        _emit(mode, e, Ve, tets, G, P, A, H, grad, data, slots, out)
    return energy, bad


#: The compiled sums of each law, by ``kind``.
SUMS = (neo_hookean_sums, yeoh_sums, hyperfoam_sums)


@jit
def scatter_add(data, slots, values):
    """data[slots[i]] += values[i] for each i with slots[i] >= 0, in order."""
    for i in range(slots.shape[0]):
        s = slots[i]
        if s >= 0:
            data[s] += values[i]
