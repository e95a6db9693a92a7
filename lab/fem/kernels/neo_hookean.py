"""The neo-Hookean law's element sums as one compiled loop over the tets (numba), on scalars.

The law of :class:`lab.fem.materials.NeoHookean`: W = mu/2 (I1 - 3) - mu ln J + lam/2 (ln J)^2,
P = mu F - c F^-T with c = mu - lam ln J, and the closed-form element Hessian
c Ag[a, k] Ag[b, i] + lam Ag[a, i] Ag[b, k] + mu (G G^T)[a, b] d_ik, Ag = G F^-1 (volumes
included). F, F^-1 and P stay in registers (the law is cheap, so arrays per tet would cost
more than the law); ``mode`` as in :mod:`lab.fem.kernels.elements`. Importing this module imports numba.
"""

from __future__ import annotations

import math

import numpy as np

from lab.fem.kernels.backend import jit
from lab.fem.kernels.elements import (
    ELEMENT_HESSIANS,
    ENERGY,
    GRADIENT,
    GRADIENT_AND_HESSIAN,
    HESSIAN,
    _fill,
    _inverse,
    deformation,
)


@jit(inline=True)
def _hessian(G, e, inv, c, lam, mu, Ag, H):
    """The element Hessian (144,) into H from F^-1 (9 scalars ``inv``), c, lam, mu (times V)."""
    i00, i01, i02, i10, i11, i12, i20, i21, i22 = inv
    for q in range(4):
        G0, G1, G2 = G[e, q, 0], G[e, q, 1], G[e, q, 2]
        Ag[q, 0] = G0 * i00 + G1 * i10 + G2 * i20
        Ag[q, 1] = G0 * i01 + G1 * i11 + G2 * i21
        Ag[q, 2] = G0 * i02 + G1 * i12 + G2 * i22
    for p in range(4):
        for q in range(4):
            gg = mu * (G[e, p, 0] * G[e, q, 0] + G[e, p, 1] * G[e, q, 1] + G[e, p, 2] * G[e, q, 2])
            for i in range(3):
                for k in range(3):
                    h = c * Ag[p, k] * Ag[q, i] + lam * Ag[p, i] * Ag[q, k]
                    if i == k:
                        h += gg
                    H[12 * (3 * p + i) + 3 * q + k] = h


@jit
def neo_hookean_sums(mode, x, tets, G, V, prm, alpha, beta, grad, data, slots, out):
    """One pass over the tets of the neo-Hookean law (prm[:, :2] = mu, lam in Pa).

    ``mode``: ENERGY; GRADIENT (dE/dx also added into ``grad`` (N, 3)); HESSIAN (element
    Hessians added into ``data`` at ``slots`` (M, 144), -1: a clamped dof, skipped);
    GRADIENT_AND_HESSIAN (both); ELEMENT_HESSIANS (into ``out`` (M, 12, 12)). Node
    positions ``x`` (N, 3) m, ``tets`` (M, 4), shape-function gradients ``G`` (M, 4, 3), rest
    volumes ``V`` (M,), per-tet parameters ``prm`` (M, 4); ``alpha``, ``beta`` unused (the
    signature of every law's loop).
    Returns (energy J, number of inverted tets); nothing is added for an inverted tet.
    """
    H, Ag = np.empty(144), np.empty((4, 3))
    energy, bad = 0.0, 0
    for e in range(tets.shape[0]):
        a, b, c, d, f, g, h, i, j = deformation(x, tets, G, e)
        c00, c10, c20 = f * j - g * i, g * h - d * j, d * i - f * h
        J = a * c00 + b * c10 + c * c20
        if not J > 0:
            bad += 1
            continue
        mu, lam, Ve = prm[e, 0], prm[e, 1], V[e]
        logJ = math.log(J)
        I1 = a * a + b * b + c * c + d * d + f * f + g * g + h * h + i * i + j * j
        energy += Ve * (0.5 * mu * (I1 - 3) - mu * logJ + 0.5 * lam * logJ * logJ)
        if mode == ENERGY:
            continue
        r = 1.0 / J
        i00, i01, i02 = c00 * r, (c * i - b * j) * r, (b * g - c * f) * r
        i10, i11, i12 = c10 * r, (a * j - c * h) * r, (c * d - a * g) * r
        i20, i21, i22 = c20 * r, (b * h - a * i) * r, (a * f - b * d) * r
        cm = mu - lam * logJ
        if mode == GRADIENT or mode == GRADIENT_AND_HESSIAN:  # V P = V (mu F - c F^-T), then G (V P)^T
            P00, P01, P02 = Ve * (mu * a - cm * i00), Ve * (mu * b - cm * i10), Ve * (mu * c - cm * i20)
            P10, P11, P12 = Ve * (mu * d - cm * i01), Ve * (mu * f - cm * i11), Ve * (mu * g - cm * i21)
            P20, P21, P22 = Ve * (mu * h - cm * i02), Ve * (mu * i - cm * i12), Ve * (mu * j - cm * i22)
            for q in range(4):
                n = tets[e, q]
                G0, G1, G2 = G[e, q, 0], G[e, q, 1], G[e, q, 2]
                grad[n, 0] += G0 * P00 + G1 * P01 + G2 * P02
                grad[n, 1] += G0 * P10 + G1 * P11 + G2 * P12
                grad[n, 2] += G0 * P20 + G1 * P21 + G2 * P22
            if mode == GRADIENT:
                continue
        inv = (i00, i01, i02, i10, i11, i12, i20, i21, i22)
        _hessian(G, e, inv, Ve * cm, Ve * lam, Ve * mu, Ag, H)
        if mode == HESSIAN or mode == GRADIENT_AND_HESSIAN:
            for r in range(144):
                s = slots[e, r]
                if s >= 0:
                    data[s] += H[r]
        elif mode == ELEMENT_HESSIANS:
            for r in range(12):
                for t in range(12):
                    out[e, r, t] = H[12 * r + t]
    return energy, bad


@jit
def neo_hookean_product(x, dx, tets, G, V, prm, out):
    """d2E/dx2 dx of the neo-Hookean law added into ``out`` (N, 3) N, one pass over the tets.

    Per tet, with dF = dx^T G and c = mu - lam ln J (times V):
    dP = mu dF + lam tr(F^-1 dF) F^-T + c (F^-1 dF F^-1)^T, then G (V dP)^T at the nodes.
    Node positions ``x`` and the direction ``dx`` (N, 3) m; the other arguments as in
    ``neo_hookean_sums``. Returns the number of inverted tets (nothing is added for them).
    """
    F, Fi, D, T = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    bad = 0
    for e in range(tets.shape[0]):
        _fill(F, deformation(x, tets, G, e))
        J = _inverse(F, Fi, True)
        if not J > 0:
            bad += 1
            continue
        _fill(D, deformation(dx, tets, G, e))
        Ve = V[e]
        mu, lam = Ve * prm[e, 0], Ve * prm[e, 1]
        cm = mu - lam * math.log(J)
        trace = 0.0
        for p in range(3):
            for s in range(3):
                trace += Fi[p, s] * D[s, p]
        for p in range(3):  # W = F^-1 dF (into T's rows, then T = W F^-1 in place, row by row)
            w0 = Fi[p, 0] * D[0, 0] + Fi[p, 1] * D[1, 0] + Fi[p, 2] * D[2, 0]
            w1 = Fi[p, 0] * D[0, 1] + Fi[p, 1] * D[1, 1] + Fi[p, 2] * D[2, 1]
            w2 = Fi[p, 0] * D[0, 2] + Fi[p, 1] * D[1, 2] + Fi[p, 2] * D[2, 2]
            for s in range(3):
                T[p, s] = w0 * Fi[0, s] + w1 * Fi[1, s] + w2 * Fi[2, s]
        for p in range(3):  # V dP = mu dF + lam tr(F^-1 dF) F^-T + c T^T, into D
            for s in range(3):
                D[p, s] = mu * D[p, s] + lam * trace * Fi[s, p] + cm * T[s, p]
        for q in range(4):
            n = tets[e, q]
            G0, G1, G2 = G[e, q, 0], G[e, q, 1], G[e, q, 2]
            for p in range(3):
                out[n, p] += G0 * D[p, 0] + G1 * D[p, 1] + G2 * D[p, 2]
    return bad
