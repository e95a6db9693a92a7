"""The hyperfoam law at one element, compiled: :func:`lab.fem.materials.hyperfoam.hyperfoam_law`
for one deformation gradient, in the same steps.

The eigenvalues c_p and vectors Q of C = F^T F by the same cyclic Jacobi rotations as the
vectorised ``_eigh3`` (stopping per element instead of when every element has converged:
the results agree to rounding), the divided differences of c^(alpha/2 - 1) in the same
cancellation-free form with the same repeated-value limit, and the tangent
A = 2k (E^T D E_s + d_ik S_lj) + k v'' F^-T (x) F^-T - k v' F^-T_il F^-1_jk, symmetrised.
Imported only by :mod:`lab.fem.kernels.elements` (numba is imported with it).
"""

from __future__ import annotations

import math

from lab.fem.kernels.backend import jit
from lab.fem.materials.elements import JACOBI_SWEEPS
from lab.fem.materials.hyperfoam import REPEATED_LOG_GAP


@jit(inline=True)
def _rotation(app, aqq, apq):
    """The Jacobi rotation (c, s, t) zeroing apq, as ``_eigh3`` (t = 0 where apq = 0)."""
    t = 0.0
    if apq != 0.0:
        theta = (aqq - app) / (2.0 * apq)
        root = abs(theta) if abs(theta) > 1e8 else math.sqrt(theta * theta + 1.0)  # (1e16 + 1 rounds to 1e16)
        t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + root)
        if not math.isfinite(t):
            t = 0.0
    c = 1.0 if abs(t) < 1e-8 else 1.0 / math.sqrt(t * t + 1.0)  # (1 + 1e-16 rounds to 1)
    return c, t * c, t


@jit
def jacobi3(C, Q, c, vectors):
    """Eigenvalues ``c`` (3,) and, if ``vectors``, eigenvectors ``Q`` (3, 3) (columns) of the
    symmetric 3x3 ``C``, by the cyclic rotations of ``lab.fem.materials.elements._eigh3``
    (planes (0, 1), (0, 2), (1, 2)), on scalars."""
    a00, a11, a22, a01, a02, a12 = C[0, 0], C[1, 1], C[2, 2], C[0, 1], C[0, 2], C[1, 2]
    q00, q01, q02, q10, q11, q12, q20, q21, q22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    for _ in range(JACOBI_SWEEPS):
        if abs(a01) + abs(a02) + abs(a12) <= 1e-18 * (abs(a00) + abs(a11) + abs(a22)):
            break
        # plane (0, 1), r = 2: a02, a12 rotate
        cs, sn, t = _rotation(a00, a11, a01)
        a00, a11, a01 = a00 - t * a01, a11 + t * a01, 0.0
        a02, a12 = cs * a02 - sn * a12, sn * a02 + cs * a12
        if vectors:
            q00, q01 = cs * q00 - sn * q01, sn * q00 + cs * q01
            q10, q11 = cs * q10 - sn * q11, sn * q10 + cs * q11
            q20, q21 = cs * q20 - sn * q21, sn * q20 + cs * q21
        # plane (0, 2), r = 1: a01 (r, p) and a12 (r, q) rotate
        cs, sn, t = _rotation(a00, a22, a02)
        a00, a22, a02 = a00 - t * a02, a22 + t * a02, 0.0
        a01, a12 = cs * a01 - sn * a12, sn * a01 + cs * a12
        if vectors:
            q00, q02 = cs * q00 - sn * q02, sn * q00 + cs * q02
            q10, q12 = cs * q10 - sn * q12, sn * q10 + cs * q12
            q20, q22 = cs * q20 - sn * q22, sn * q20 + cs * q22
        # plane (1, 2), r = 0: a01 (r, p) and a02 (r, q) rotate
        cs, sn, t = _rotation(a11, a22, a12)
        a11, a22, a12 = a11 - t * a12, a22 + t * a12, 0.0
        a01, a02 = cs * a01 - sn * a02, sn * a01 + cs * a02
        if vectors:
            q01, q02 = cs * q01 - sn * q02, sn * q01 + cs * q02
            q11, q12 = cs * q11 - sn * q12, sn * q11 + cs * q12
            q21, q22 = cs * q21 - sn * q22, sn * q21 + cs * q22
    c[0], c[1], c[2] = a00, a11, a22
    Q[0, 0], Q[0, 1], Q[0, 2] = q00, q01, q02
    Q[1, 0], Q[1, 1], Q[1, 2] = q10, q11, q12
    Q[2, 0], Q[2, 1], Q[2, 2] = q20, q21, q22


@jit(inline=True)
def _divided(la, lb, p):
    """(c_a^p - c_b^p) / (c_a - c_b) from the logs la, lb (``_divided_power``'s form)."""
    m, x = 0.5 * (la + lb), 0.5 * (la - lb)
    if abs(x) < 0.5 * REPEATED_LOG_GAP:
        ratio = p * (1.0 + (p * p - 1.0) * x * x / 6.0)
    else:
        ratio = math.sinh(p * x) / math.sinh(x)
    return math.exp((p - 1.0) * m) * ratio


@jit
def foam_element(F, Fi, J, mu, alpha, beta, order, P, A, w):
    """Energy density (J/m^3) of the hyperfoam law at F (3, 3) with inverse Fi and det J > 0;
    with ``order`` >= 1 the stress P (3, 3) Pa, with order 2 the tangent A (9, 9) Pa (rows
    (i, j), columns (k, l)). ``w`` (8, 9, 9) is scratch. NaN where an eigenvalue of C is
    not positive (a tet squashed flat: inverted)."""
    C, Q, E, Es = w[0, :3, :3], w[1, :3, :3], w[2], w[3]
    c, lc, Sd = w[4, 0, :3], w[4, 1, :3], w[4, 2, :3]
    FQ, S, D = w[5, :3, :3], w[6, :3, :3], w[7, :3, :3]
    for i in range(3):
        for j in range(3):
            C[i, j] = F[0, i] * F[0, j] + F[1, i] * F[1, j] + F[2, i] * F[2, j]
    jacobi3(C, Q, c, order > 0)
    for p in range(3):
        if not c[p] > 0:
            return math.nan
        lc[p] = math.log(c[p])
    s, k = math.log(J), 2.0 * mu / (alpha * alpha)
    e = math.exp(-alpha * beta * s)
    v = math.expm1(-alpha * beta * s) / beta if beta > 0 else -alpha * s
    v1, v2 = -alpha * e, alpha * alpha * beta * e
    W = k * (math.expm1(0.5 * alpha * lc[0]) + math.expm1(0.5 * alpha * lc[1]) + math.expm1(0.5 * alpha * lc[2]) + v)
    if order == 0:
        return W
    for p in range(3):
        Sd[p] = 0.5 * alpha * math.exp((0.5 * alpha - 1.0) * lc[p])
    for i in range(3):
        for j in range(3):
            FQ[i, j] = F[i, 0] * Q[0, j] + F[i, 1] * Q[1, j] + F[i, 2] * Q[2, j]
            S[i, j] = Q[i, 0] * Sd[0] * Q[j, 0] + Q[i, 1] * Sd[1] * Q[j, 1] + Q[i, 2] * Sd[2] * Q[j, 2]
    for i in range(3):
        for j in range(3):
            P[i, j] = 2.0 * k * (F[i, 0] * S[0, j] + F[i, 1] * S[1, j] + F[i, 2] * S[2, j]) + k * v1 * Fi[j, i]
    if order < 2:
        return W
    pw = 0.5 * alpha - 1.0
    for p in range(3):
        for q in range(3):
            D[p, q] = 0.5 * alpha * _divided(lc[p], lc[q], pw)
    # E[(p, q), (i, j)] = f_p[i] q_q[j] with f_p = F q_p; Es adds E[(q, p)]; A = E^T D Es.
    for p in range(3):
        for q in range(3):
            for i in range(3):
                for j in range(3):
                    E[3 * p + q, 3 * i + j] = FQ[i, p] * Q[j, q]
    for p in range(3):
        for q in range(3):
            for r in range(9):
                Es[3 * p + q, r] = D[p, q] * (E[3 * p + q, r] + E[3 * q + p, r])
    for r in range(9):
        for t in range(9):
            acc = 0.0
            for pq in range(9):
                acc += E[pq, r] * Es[pq, t]
            A[r, t] = acc
    for i in range(3):
        for j in range(3):
            for kk in range(3):
                for ll in range(3):
                    a = A[3 * i + j, 3 * kk + ll]
                    if i == kk:
                        a += S[j, ll]
                    a *= 2.0 * k
                    a += k * v2 * Fi[j, i] * Fi[ll, kk] - k * v1 * Fi[ll, i] * Fi[j, kk]
                    A[3 * i + j, 3 * kk + ll] = a
    for r in range(9):
        for t in range(r + 1, 9):
            m = 0.5 * (A[r, t] + A[t, r])
            A[r, t] = A[t, r] = m
    return W
