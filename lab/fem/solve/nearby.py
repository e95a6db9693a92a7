"""Sensitivities at an equilibrium from the factorisation of the Newton iterate that found it.

:func:`lab.fem.solve.statics.solve_static` ends with a Newton step of at most ``tol_step_m``
from the iterate it factorised (or with chord steps from one farther back), so the Hessian H
at the equilibrium differs from the factorised one, H_f, by a small perturbation: mostly the
condensed law's stiffness (a taut cable's spring, in its smoothing zone, changes a lot within
a micrometre) and the soft bending mode (~0.015 N/m, which stiffens or softens by tens of %
within 10 um), so H_f^-1 is off by ~1e-3 relative even 1e-7 m away. :func:`nearby_preconditioner`
applies H_f^-1 with the condensed law's change corrected exactly (Woodbury, a k x k solve, as
:func:`lab.fem.solve.steps.reused_sensitivity`); :func:`refined_solve` makes a few right-hand
sides exact to round-off by preconditioned conjugate gradients with the Hessian assembled at
the equilibrium (two or three iterations: sparse products and solves with H_f, no new
factorisation). A solve that does not settle returns None: the caller factorises afresh.

:func:`nearby_sensitivities` serves the calibration (:mod:`lab.transfer.samples`): the
observed markers' rows J = S dq/dtheta = -(H^-1 S^T)^T dg/dtheta exact to round-off (an
adjoint solve, 3K right-hand sides), dq/dtheta itself only as a predictor of the next
equilibrium (H_f^-1 alone). What it saves is the factorisation, not the assembly; measured in
a calibration on the default mesh (``benchmarks/bench_calibrate_speed.py``'s notes in
docs/design/transfer.md): about a tenth of a sensitivity's cost where the factorisation is
near, and 60 % of the solves end with chord steps, whose factorisation is too far to serve.
"""

from __future__ import annotations

import numpy as np

__all__ = ["near_enough", "nearby_preconditioner", "nearby_sensitivities", "refined_solve"]

#: Farthest (largest coordinate, m) an equilibrium may lie from the factorised iterate: a
#: converging Newton step (``tol_step_m``, 1e-7 m by default) is; chord steps can end up to
#: ~1 mm away, where the soft bending mode has changed too much to precondition well.
NEAR_M = 1e-6
#: Conjugate-gradient iterations of :func:`refined_solve` before it gives up.
CG_ITERATIONS = 8
#: Converged when an update changes what is wanted of the solution by less than this,
#: relative to its largest entry; the error left is then ~1e-12, what a direct solve with
#: the exact Hessian attains (PARDISO and SuperLU agree to ~1e-12 on the default mesh).
RTOL = 1e-10


def nearby_preconditioner(fac, condensation):
    """r -> an approximation of H^-1 r at the equilibrium from the factorisation ``fac``.

    Parameters
    ----------
    fac : Factorised
        The factorisation of a nearby Newton iterate (:class:`lab.fem.solve.factorised.Factorised`).
    condensation : Condensation or None
        The actuators' condensation at the equilibrium.

    Returns
    -------
    callable
        r (n_free,) or (n_free, k) in N -> the solution(s) in m, same shape.
    """
    if condensation is None or fac.A is None or not condensation.in_hessian or fac.A.shape != condensation.A.shape:
        return fac.solve  # nothing to correct (a rank term not in H: its law is linear)
    dK = condensation.at_stretch()[2] - fac.K
    W = np.linalg.inv(np.eye(len(dK)) + dK[:, None] * fac.C)

    def apply(r):
        z = fac.lu.solve(r)
        D = dK.reshape((-1,) + (1,) * (np.ndim(z) - 1))
        return z - fac.S @ (W @ (D * (fac.A.T @ z)))

    return apply


def refined_solve(hessian, precondition, R, weights, *, max_iter: int = CG_ITERATIONS, rtol: float = RTOL):
    """X with H X = R by preconditioned conjugate gradients, the columns side by side (one
    preconditioner call per iteration for all of them), accurate in what the caller wants of
    it: W^T X, W = ``weights``.

    A column stops once two updates in a row change its W^T x by less than ``rtol`` of the
    largest entry of W^T X. With a nearby factorisation the updates contract by 1e-3 to 1e-5
    an iteration; with a far one (rest, for a bent arm) they contract slowly and erratically,
    and one small update could stop a column 1.5e-9 (relative) from the solution.

    Parameters
    ----------
    hessian : callable
        V (n_free, j) m -> H V (n_free, j) N, exact at the equilibrium (H symmetric positive definite).
    precondition : callable
        r (n_free, k) N -> approximately H^-1 r, m (:func:`nearby_preconditioner`).
    R : ndarray, shape (n_free, k)
        Right-hand sides, N.
    weights : ndarray, shape (n_free, l)
        W, N per unit of what is wanted (the force derivatives, for sensitivities).
    max_iter : int
        Most iterations.
    rtol : float
        Relative accuracy asked for.

    Returns
    -------
    X : ndarray, shape (n_free, k) or None
        The solutions, m; None if a column did not settle (or H is not positive along it).
    products : int
        Hessian products spent.
    """
    R = np.asarray(R, float)
    k = R.shape[1]
    X = precondition(R)
    res = R - hessian(X)
    products = k
    scale = np.max(np.abs(X.T @ weights))
    Z = precondition(res)
    P, rz = Z.copy(), np.einsum("ij,ij->j", res, Z)
    active = np.ones(k, bool)
    last = np.full(k, np.inf)  # each column's previous update of W^T x (largest entry)
    for _ in range(max_iter):
        cols = np.flatnonzero(active)
        HP = hessian(P[:, cols])
        products += len(cols)
        curvature = np.einsum("ij,ij->j", P[:, cols], HP)
        if not np.all(curvature > 0):
            return None, products
        step = (rz[cols] / curvature) * P[:, cols]
        X[:, cols] += step
        res[:, cols] -= (rz[cols] / curvature) * HP
        size = np.max(np.abs(step.T @ weights), axis=1)
        settled = np.maximum(size, last[cols]) <= rtol * scale  # two updates in a row
        last[cols] = size
        active[cols[settled]] = False
        if not active.any():
            return X, products
        cols = np.flatnonzero(active)
        Z = precondition(res[:, cols])
        rz_new = np.einsum("ij,ij->j", res[:, cols], Z)
        P[:, cols] = Z + (rz_new / rz[cols]) * P[:, cols]
        rz[cols] = rz_new
    return None, products


def near_enough(fac, distance_m) -> bool:
    """Whether a solve's last factorisation may serve at its equilibrium (:data:`NEAR_M`).

    Parameters
    ----------
    fac : Factorised or None
        The solve's last exact factorisation.
    distance_m : float or None
        How far the equilibrium lies from the factorised iterate (largest coordinate, m).

    Returns
    -------
    bool
        True where :func:`nearby_sensitivities` tries it (it may still find it does not serve).
    """
    return fac is not None and distance_m is not None and distance_m <= NEAR_M


def nearby_sensitivities(fem, q, u, B, S, fac, condensation, distance_m=0.0):
    """dq = -H^-1 B and the observed rows J = S dq at the equilibrium ``q`` without a new
    factorisation: J exact to round-off by the adjoint solve H Y = S^T refined with Hessian
    products at q (:func:`refined_solve`), dq (a predictor) from the
    nearby factorisation ``fac`` with the condensed law corrected.

    Parameters
    ----------
    fem : ArmFEM
        The model.
    q : ndarray, shape (n_free,)
        The equilibrium, m.
    u : ndarray, shape (m,)
        Its inputs.
    B : ndarray, shape (n_free, k)
        The force derivatives (N per unit of each input and parameter).
    S : scipy.sparse matrix, shape (3K, n_free)
        The observed markers' rows (:func:`lab.fem.solve.parameters.marker_rows`).
    fac : Factorised or None
        The solve's last exact factorisation (:class:`~lab.fem.solve.factorised.Factorised`).
    condensation : Condensation or None
        The condensation at q.
    distance_m : float or None
        How far q lies from the factorised iterate (largest coordinate, m); beyond
        :data:`NEAR_M` the factorisation is not used.

    Returns
    -------
    tuple or None
        dq (n_free, k) and J (3K, k); None where ``fac`` does not serve (none, or the
        refinement did not settle): the caller factorises afresh.
    """
    if not near_enough(fac, distance_m):
        return None
    precondition = nearby_preconditioner(fac, condensation)
    H = fem.hessian(q, u)
    if condensation is not None and not condensation.in_hessian:  # its rank-k term, left out of H
        A, K = condensation.A, condensation.at_stretch()[2]

        def hessian(V):
            return H @ V + A @ (K[:, None] * (A.T @ V))
    else:

        def hessian(V):
            return H @ V

    Y, _ = refined_solve(hessian, precondition, S.T.toarray(), B)
    if Y is None:
        return None
    return -precondition(B), -(Y.T @ B)
