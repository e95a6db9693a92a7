"""The steps of :func:`lab.fem.statics.solve_static`, and sensitivities from a reused factorisation.

:func:`newton_step`: cable-condensed Newton steps. A taut cable often sits inside its 0.2 mm
smoothing zone, where Newton's quadratic model of the spring is poor, so each step keeps the
spring law tau(d) exact in the m-dimensional space of cable stretches d = L - L* (m) and
linearises the rest: an m-dimensional equation for the stretch change (:func:`condensed_step`)
around one (m + 1)-column solve with the factorisation; it has Newton's fixed point.
:func:`secant_step`: chord steps near the equilibrium, reusing that factorisation with BFGS
updates. :func:`shifted_step`: H + s I where the exact Hessian is indefinite (``SHIFTS``).
:func:`reused_sensitivity`: dq/du = -H^-1 d2E/dq du (m/rad) from the last factorisation, the
springs' stiffness corrected exactly (Woodbury) and the rest refined by conjugate gradients.

The derivation and the measurements behind each step: docs/design/fem.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from lab.fem.energy import ArmFEM
from lab.fem.linsolve import SingularMatrixError, factorize

#: Diagonal shifts tried, as fractions of the median diagonal entry, where the exact
#: Hessian is indefinite.
SHIFTS = (1e-3, 1e-2)
#: At most REFINE_ITERATIONS conjugate-gradient iterations per refined direction,
#: stopped when an update changes dq/du du by less than REFINE_TOL of its size.
REFINE_ITERATIONS = 2
REFINE_TOL = 1e-4


@dataclass
class Factorised:
    """The exact Hessian factorised at an iterate where it is positive definite, with
    what condensed steps need from that point: A = dL/dq (n_free, m), S = H^-1 A,
    C = A^T S (m, m) in m/N, spring stiffnesses K (m,) in N/m."""

    lu: object
    A: np.ndarray
    S: np.ndarray
    C: np.ndarray
    K: np.ndarray


def newton_step(fem: ArmFEM, H: sp.csr_matrix, g, stretch, A):
    """The cable-condensed Newton step (n_free,) m for the exact Hessian ``H``, gradient
    ``g``, cable stretches ``stretch`` (m,) m and A = dL/dq, with the
    :class:`Factorised` it came from: (dq, fac), or (None, None) if H is not positive
    definite or gives no descent."""
    try:
        lu = factorize(H)
    except SingularMatrixError:
        return None, None
    if lu.n_negative:
        return None, None
    Z = lu.solve(np.column_stack([-g, A]))
    fac = Factorised(lu, A, Z[:, 1:], A.T @ Z[:, 1:], fem.cable_springs(stretch)[2])
    for d in (condensed_step(fem, fac, Z[:, 0], stretch), Z[:, 0]):  # else the plain Newton step
        if np.all(np.isfinite(d)) and g @ d < 0:
            return d, fac
    return None, None


def shifted_step(H: sp.csr_matrix, g):
    """A descent step with H + s I, s the first of ``SHIFTS`` (times the median diagonal
    entry) that makes it positive definite: (dq or None, factorisations used). Shifts
    ``H`` in place (same sparsity pattern, so no new symbolic analysis)."""
    scale = float(np.median(H.diagonal()))
    added = 0.0
    for i, s in enumerate(SHIFTS):
        H.setdiag(H.diagonal() + (s - added) * scale)
        added = s
        try:
            lu = factorize(H)
        except SingularMatrixError:
            continue
        if not lu.n_negative:
            d = -lu.solve(g)
            return (d if np.all(np.isfinite(d)) and g @ d < 0 else None), i + 1
    return None, len(SHIFTS)


def secant_step(lu, pairs, g) -> np.ndarray:
    """-H^-1 g (n_free,) with H^-1 the factorisation ``lu``'s inverse updated by BFGS
    with the secant pairs (s, y, 1 / s.y) of the steps taken since it was computed
    (L-BFGS two-loop recursion): a chord step that learns, along the directions it
    moves in, how far the Hessian has changed since; that is mostly the soft mode."""
    z = -np.asarray(g, dtype=float)
    alphas = []
    for s, y, rho in reversed(pairs):
        alphas.append(rho * (s @ z))
        z = z - alphas[-1] * y
    z = lu.solve(z)
    for (s, y, rho), a in zip(pairs, reversed(alphas)):
        z = z + (a - rho * (y @ z)) * s
    return z


def condensed_step(fem: ArmFEM, fac: Factorised, d_newton: np.ndarray, stretch: np.ndarray) -> np.ndarray:
    """The cable-condensed step dq = d_newton + S psi(e) (module docstring) for the step
    ``d_newton`` = -H^-1 g (n_free,) of the factorisation ``fac`` and the cable
    stretches ``stretch`` (m,) m where it starts (fac may be from an earlier iterate: a
    chord step); ``d_newton`` itself if the equation for e does not settle."""
    tau = fem.cable_springs(stretch)[1]
    e_newton = fac.A.T @ d_newton
    e = e_newton.copy()
    scale = max(float(np.max(np.abs(e_newton))), fem.robot.slack_smoothing_m)
    for _ in range(50):
        _, tau_e, k_e = fem.cable_springs(stretch + e)
        F = e - e_newton - fac.C @ (tau + fac.K * e - tau_e)
        de = -np.linalg.solve(np.eye(len(e)) - fac.C * (fac.K - k_e)[None, :], F)
        e += de
        if not np.all(np.isfinite(e)):
            break
        if np.max(np.abs(de)) <= 1e-12 * scale:
            return d_newton + fac.S @ (tau + fac.K * e - fem.cable_springs(stretch + e)[1])
    return d_newton


def reused_sensitivity(fem: ArmFEM, fac: Factorised, q, u, stretch, A, refine_du=None) -> np.ndarray:
    """dq/du (n_free, m) in m/rad at the equilibrium ``q`` for motor angles ``u`` (cable
    stretches ``stretch`` (m,) m and A = dL/dq there), from the factorisation ``fac`` of
    a nearby iterate, accurate along the rows of ``refine_du`` (k, m) rad if given.

    dq/du = -H^-1 d2E/dq du with d2E/dq du = r A K. With H = H_f + A (K - K_f) A^T the
    springs' stiffness change is exact (Woodbury: an m x m solve). Along each direction
    du, v = dq/du du is then refined by conjugate gradients on H v = -d2E/dq du du,
    preconditioned with that, with exact Hessian products at q
    (:meth:`lab.fem.energy.ArmFEM.hessian_operator`): three products and two solves."""
    K = fem.cable_springs(stretch)[2]
    dK = K - fac.K
    W = np.linalg.inv(np.eye(len(K)) + dK[:, None] * fac.C)

    def precondition(R):
        Z = fac.lu.solve(R)
        return Z - fac.S @ (W @ (dK * (fac.A.T @ Z)))

    r_K = fem.robot.spool_radius_m * K
    D = -fac.S @ (W * r_K[None, :])
    U = []  # unit directions, none parallel
    for du in np.zeros((0, len(K))) if refine_du is None else np.atleast_2d(np.asarray(refine_du, float)):
        n = np.linalg.norm(du)
        if n > 0 and all(abs(du @ w) < (1 - 1e-9) * n for w in U):
            U.append(du / n)
    if not U:
        return D
    U = np.array(U)  # (k, m)
    V = np.empty((len(q), len(U)))
    hessian = fem.hessian_operator(q, u)
    for i, du in enumerate(U):
        v = D @ du
        r = -(hessian(v) + A @ (r_K * du))  # -(H v + d2E/dq du du)
        z = precondition(r)
        p, rz = z, r @ z
        for k in range(REFINE_ITERATIONS):
            if np.max(np.abs(p)) <= REFINE_TOL * np.max(np.abs(v)):
                break  # accurate already (e.g. a slack cable)
            Hp = hessian(p)
            curvature = p @ Hp
            if not curvature > 0:
                break
            alpha = rz / curvature
            v = v + alpha * p
            if k + 1 == REFINE_ITERATIONS or np.max(np.abs(alpha * p)) <= REFINE_TOL * np.max(np.abs(v)):
                break
            r = r - alpha * Hp
            z = precondition(r)
            rz, rz_old = r @ z, rz
            p = z + (rz / rz_old) * p
        V[:, i] = v
    # The least change of D that makes D U^T = V.
    return D + (V - D @ U.T) @ np.linalg.pinv(U.T)
