"""The element sums of the laws given by their tangent, each one compiled loop over the tets (numba).

``yeoh_sums`` and ``hyperfoam_sums`` (the foam law at an element in :mod:`lab.fem.kernels.foam`)
visit each tet once: F from its four nodes (``deformation``, shared with the
neo-Hookean loop of :mod:`lab.fem.kernels.neo_hookean`), the law's energy density, stress or tangent A at F,
and then, by ``mode``, the energy alone, the energy and the nodal gradient, the element
Hessian H[(a, i), (b, k)] = sum_jl G[a, j] V A[(i, j), (k, l)] G[b, l] (two small
contractions) added straight into the CSR data of the global Hessian through each entry's
precomputed slot, the dense element Hessians, or the tangents. Small helpers are inlined
(no call and no reference counting per tet). Importing this module imports numba
(:func:`lab.fem.kernels.backend.jit`).
"""

from __future__ import annotations

import math

import numpy as np

from lab.fem.kernels.backend import jit
from lab.fem.kernels.foam import foam_element

#: What a loop computes (``mode``); GRADIENT_AND_HESSIAN: the gradient and the Hessian in one pass.
ENERGY, GRADIENT, HESSIAN, ELEMENT_HESSIANS, TANGENTS, GRADIENT_AND_HESSIAN = 0, 1, 2, 3, 4, 5


@jit(inline=True)
def deformation(x, tets, G, e):
    """F of tet ``e`` as 9 scalars, row by row: F_ij = sum_a x[tets[e, a], i] G[e, a, j]."""
    n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
    g00, g01, g02, g10, g11, g12 = G[e, 0, 0], G[e, 0, 1], G[e, 0, 2], G[e, 1, 0], G[e, 1, 1], G[e, 1, 2]
    g20, g21, g22, g30, g31, g32 = G[e, 2, 0], G[e, 2, 1], G[e, 2, 2], G[e, 3, 0], G[e, 3, 1], G[e, 3, 2]
    a0, a1, a2, a3 = x[n0, 0], x[n1, 0], x[n2, 0], x[n3, 0]
    b0, b1, b2, b3 = x[n0, 1], x[n1, 1], x[n2, 1], x[n3, 1]
    c0, c1, c2, c3 = x[n0, 2], x[n1, 2], x[n2, 2], x[n3, 2]
    return (
        a0 * g00 + a1 * g10 + a2 * g20 + a3 * g30,
        a0 * g01 + a1 * g11 + a2 * g21 + a3 * g31,
        a0 * g02 + a1 * g12 + a2 * g22 + a3 * g32,
        b0 * g00 + b1 * g10 + b2 * g20 + b3 * g30,
        b0 * g01 + b1 * g11 + b2 * g21 + b3 * g31,
        b0 * g02 + b1 * g12 + b2 * g22 + b3 * g32,
        c0 * g00 + c1 * g10 + c2 * g20 + c3 * g30,
        c0 * g01 + c1 * g11 + c2 * g21 + c3 * g31,
        c0 * g02 + c1 * g12 + c2 * g22 + c3 * g32,
    )


@jit(inline=True)
def _fill(F, f):
    """The 9 scalars ``f`` of ``deformation`` into the (3, 3) array F."""
    F[0, 0], F[0, 1], F[0, 2], F[1, 0], F[1, 1], F[1, 2], F[2, 0], F[2, 1], F[2, 2] = f


@jit(inline=True)
def _inverse(F, Fi, want):
    """det F; and, if ``want``, F^-1 into Fi where det F > 0 (the adjugate over the determinant)."""
    a, b, c = F[0, 0], F[0, 1], F[0, 2]
    d, e, f = F[1, 0], F[1, 1], F[1, 2]
    g, h, i = F[2, 0], F[2, 1], F[2, 2]
    c00, c10, c20 = e * i - f * h, f * g - d * i, d * h - e * g
    J = a * c00 + b * c10 + c * c20
    if J > 0 and want:
        r = 1.0 / J
        Fi[0, 0], Fi[0, 1], Fi[0, 2] = c00 * r, (c * h - b * i) * r, (b * f - c * e) * r
        Fi[1, 0], Fi[1, 1], Fi[1, 2] = c10 * r, (a * i - c * g) * r, (c * d - a * f) * r
        Fi[2, 0], Fi[2, 1], Fi[2, 2] = c20 * r, (b * g - a * h) * r, (a * e - b * d) * r
    return J


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


@jit(inline=True)
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


@jit(inline=True)
def _emit(mode, e, Ve, tets, G, P, A, H, grad, data, slots, out):
    """Tet e's share by ``mode``: V G P^T into ``grad``, V A into ``out``, or its Hessian H
    (144,) into ``data`` at ``slots[e]`` (with the gradient too: GRADIENT_AND_HESSIAN) or
    into ``out[e]``."""
    if mode == GRADIENT or mode == GRADIENT_AND_HESSIAN:
        for a in range(4):
            n = tets[e, a]
            for i in range(3):
                grad[n, i] += Ve * (G[e, a, 0] * P[i, 0] + G[e, a, 1] * P[i, 1] + G[e, a, 2] * P[i, 2])
    if mode == TANGENTS:
        for r in range(9):
            for t in range(9):
                out[e, r, t] = Ve * A[r, t]
    if mode == HESSIAN or mode == GRADIENT_AND_HESSIAN:
        for r in range(144):
            s = slots[e, r]
            if s >= 0:
                data[s] += H[r]
    elif mode == ELEMENT_HESSIANS:
        for r in range(12):
            for t in range(12):
                out[e, r, t] = H[12 * r + t]


@jit
def yeoh_sums(mode, x, tets, G, V, prm, alpha, beta, grad, data, slots, out):
    """One pass over the tets of the Yeoh law (prm = c10, c20, c30, kappa in Pa).

    ``mode``: ENERGY; GRADIENT (dE/dx also added into ``grad`` (N, 3)); HESSIAN (element
    Hessians added into ``data`` at ``slots`` (M, 144), -1: a clamped dof, skipped);
    GRADIENT_AND_HESSIAN (both); ELEMENT_HESSIANS (into ``out`` (M, 12, 12)); TANGENTS
    (V A into ``out`` (M, 9, 9)).
    Node positions ``x`` (N, 3) m, ``tets`` (M, 4), shape-function gradients ``G`` (M, 4, 3),
    rest volumes ``V`` (M,), per-tet parameters ``prm`` (M, 4) and the foam's exponents
    ``alpha``, ``beta`` (unused here). Returns (energy J, number of inverted tets); nothing is
    added for an inverted tet."""
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
        _fill(F, deformation(x, tets, G, e))
        J = _inverse(F, Fi, mode != ENERGY)
        if not J > 0:
            bad += 1
            continue
        Ve = V[e]
        energy += Ve * _yeoh(F, Fi, J, prm[e, 0], prm[e, 1], prm[e, 2], prm[e, 3], order, P, A)
        if mode == HESSIAN or mode == ELEMENT_HESSIANS or mode == GRADIENT_AND_HESSIAN:
            _contract(G, e, Ve, A, T, H)
        if mode != ENERGY:
            _emit(mode, e, Ve, tets, G, P, A, H, grad, data, slots, out)
    return energy, bad


@jit
def hyperfoam_sums(mode, x, tets, G, V, prm, alpha, beta, grad, data, slots, out):
    """``yeoh_sums`` for the hyperfoam law (prm[:, 0] = mu in Pa; ``alpha``, ``beta``)."""
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
        _fill(F, deformation(x, tets, G, e))
        J = _inverse(F, Fi, mode != ENERGY)
        W = foam_element(F, Fi, J, prm[e, 0], alpha, beta, order, P, A, w) if J > 0 else math.nan
        if math.isnan(W):  # inverted, or squashed flat (an eigenvalue of C not positive)
            bad += 1
            continue
        Ve = V[e]
        energy += Ve * W
        if mode == HESSIAN or mode == ELEMENT_HESSIANS or mode == GRADIENT_AND_HESSIAN:
            _contract(G, e, Ve, A, T, H)
        if mode != ENERGY:
            _emit(mode, e, Ve, tets, G, P, A, H, grad, data, slots, out)
    return energy, bad


@jit
def volume_ratios(x, tets, G, out):
    """det F of every tet into ``out`` (M,): its volume over its rest volume (node positions
    ``x`` (N, 3) m, ``tets`` (M, 4), shape-function gradients ``G`` (M, 4, 3))."""
    F = np.empty((3, 3))
    for e in range(tets.shape[0]):
        _fill(F, deformation(x, tets, G, e))
        out[e] = _inverse(F, F, False)  # det F only


@jit
def scatter_add(data, slots, values):
    """data[slots[i]] += values[i] for each i with slots[i] >= 0, in order."""
    for i in range(slots.shape[0]):
        s = slots[i]
        if s >= 0:
            data[s] += values[i]
