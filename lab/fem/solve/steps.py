"""The steps of :func:`lab.fem.solve.statics.solve_static`, and sensitivities from a reused factorisation.

``newton_step``: condensed Newton steps. An actuator may ask the statics for a
:class:`~lab.fem.actuators.Condensation`: k coordinates e = A^T dq along which its force is
a stiff one-dimensional law tau(e) (the cables: a taut cable often sits inside its 0.2 mm
smoothing zone, where Newton's quadratic model of the spring is poor). Each step keeps that
law exact in those k coordinates and linearises the rest: a k-dimensional equation
(``condensed_step``) around one (k + 1)-column solve with the factorisation (its forward
half alone, with a Cholesky factor: :mod:`lab.fem.solve.factorised`); it has
Newton's fixed point. ``secant_step``: chord steps near the equilibrium, reusing that
factorisation with BFGS updates. ``shifted_step``: H + s I where the exact Hessian is
indefinite (``SHIFTS``). ``reused_sensitivity``: dq/du = -H^-1 d2E/dq du from the last
factorisation, the condensed law's stiffness corrected exactly (Woodbury) and the rest
refined by conjugate gradients.

A condensation not in the Hessian (``Condensation.in_hessian`` False: a volume-controlled
chamber, whose fluid stiffness (K/V0) dV/dq dV/dq^T couples all its wall's dofs) has a
linear law: its rank-k term A K A^T is left out of the assembled H and added exactly by
Woodbury, (H + A K A^T)^-1 = H^-1 - S (I + K C)^-1 K S^T: ``newton_step`` factorises H
with ``fac.K = 0``, so that ``condensed_step`` is exactly the Newton step of H + A K A^T;
``Factorised.solve`` applies that inverse (chord, shifted and projected steps). Such a law
is stiff (water: K/V0 ~ 1e14 J/m^6) and the pressure p = -tau it gives away from the
equilibrium meaningless (a 1e-8 m^3 error in V is MPa), so the statics assemble H with its
follower term -p d2V/dq2 at the least-squares multiplier estimate (``hessian_inputs``),
which is p itself at the equilibrium.

The derivation and the measurements behind each step: docs/design/fem.md.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from lab.fem.actuators.base import Condensation
from lab.fem.model import ArmFEM
from lab.fem.solve.factorised import Direction, Factorised
from lab.fem.solve.linsolve import SingularMatrixError, factorize

#: Diagonal shifts tried, as fractions of the median diagonal entry, where the exact
#: Hessian is indefinite.
SHIFTS = (1e-3, 1e-2)
#: At most REFINE_ITERATIONS conjugate-gradient iterations per refined direction,
#: stopped when an update changes dq/du du by less than REFINE_TOL of its size.
REFINE_ITERATIONS = 2
REFINE_TOL = 1e-4


def newton_step(H: sp.csr_matrix, g, condensation: Condensation | None):
    """The condensed Newton step for the exact Hessian.

    Parameters
    ----------
    H : scipy.sparse.csr_matrix, shape (n_free, n_free)
        The exact Hessian, N/m.
    g : ndarray, shape (n_free,)
        The gradient, N.
    condensation : Condensation or None
        The actuators' condensation at this iterate (None: a plain Newton step).

    Returns
    -------
    dq : ndarray, shape (n_free,) or None
        The step, m; None if H is not positive definite or gives no descent.
    fac : Factorised or None
        The factorisation it came from.
    """
    try:
        lu = factorize(H)
    except SingularMatrixError:
        return None, None
    if lu.n_negative:
        return None, None
    if condensation is None:
        d = -lu.solve(g)
        fac, tries = Factorised(lu, None, None, None, None), (lambda: d,)
    else:
        fac, newton = condensed_factorisation(lu, g, condensation)
        tries = (lambda: condensed_step(fac, newton, condensation), lambda: newton.d)  # else plain Newton
    for step in tries:
        d = step()
        if np.all(np.isfinite(d)) and g @ d < 0:
            return d, fac
    return None, None


def condensed_factorisation(lu, g, condensation: Condensation):
    """What condensed steps need from the factorisation ``lu`` of H (module docstring).

    Parameters
    ----------
    lu : object
        The factorisation of H (its ``solve``; its forward halves where it has them).
    g : ndarray, shape (n_free,)
        The gradient, N.
    condensation : Condensation
        The condensation at this iterate.

    Returns
    -------
    fac : Factorised
        With A, S = H^-1 A (or its forward half Y), C = A^T S, and the law's stiffness in
        ``K`` (in H) or in ``rank_K`` (``in_hessian`` False; then ``K`` is zero).
    newton : Direction
        -H^-1 g, m.
    """
    A = condensation.A
    K = condensation.at_stretch()[2]
    K, rank_K = (K, None) if condensation.in_hessian else (np.zeros_like(K), K)
    if getattr(lu, "half_solves", False):  # C = Y^T Y from forward halves alone
        Y = lu.forward(np.column_stack([-g, A]))
        fac = Factorised(lu, A, None, Y[:, 1:].T @ Y[:, 1:], K, rank_K, Y=Y[:, 1:])
        return fac, Direction(fac, y=Y[:, 0])
    Z = lu.solve(np.column_stack([-g, A]))
    fac = Factorised(lu, A, Z[:, 1:], A.T @ Z[:, 1:], K, rank_K)
    return fac, Direction(fac, d=Z[:, 0])


def hessian_inputs(u, g, condensation: Condensation | None):
    """The inputs at which to assemble the Hessian of a Newton step at an iterate.

    ``u`` itself, except for a condensation not in the Hessian (its law linear): there
    its force tau is replaced by the least-squares multiplier estimate
    tau_hat = tau - (A^T A)^-1 A^T g (what the other forces ask of it; tau itself where
    g = 0), by moving its inputs by (tau_hat - tau) / (gain K).

    Parameters
    ----------
    u : ndarray, shape (n_inputs,)
        The inputs.
    g : ndarray, shape (n_free,)
        The gradient at the iterate, N.
    condensation : Condensation or None
        The condensation there.

    Returns
    -------
    ndarray, shape (n_inputs,)
        The inputs for :meth:`lab.fem.model.ArmFEM.hessian`.
    """
    if condensation is None or condensation.in_hessian:
        return u
    A = condensation.A
    K = condensation.at_stretch()[2]
    shift = -np.linalg.lstsq(A, g, rcond=None)[0]  # tau_hat - tau
    u_hat = np.array(u, dtype=float)
    u_hat[condensation.inputs] += shift / (condensation.gain * K)
    return u_hat


def rank_step(lu, g, condensation: Condensation | None) -> np.ndarray:
    """-(H + A K A^T)^-1 g for a condensation not in H (``lu`` factorises H), else -H^-1 g.

    Parameters
    ----------
    lu : object
        The factorisation of H (its ``solve``).
    g : ndarray, shape (n_free,)
        The gradient, N.
    condensation : Condensation or None
        The condensation at this iterate.

    Returns
    -------
    ndarray, shape (n_free,)
        The step, m.
    """
    if condensation is None or condensation.in_hessian:
        return -lu.solve(g)
    fac, newton = condensed_factorisation(lu, g, condensation)
    return condensed_step(fac, newton, condensation)


def shifted_step(H: sp.csr_matrix, g, condensation: Condensation | None = None):
    """A descent step with H + s I, s the first of ``SHIFTS`` (times the median diagonal
    entry) that makes it positive definite: (dq or None, factorisations used). Shifts
    ``H`` in place (same sparsity pattern, so no new symbolic analysis). A condensation
    not in H adds its rank-k term (:func:`rank_step`; still positive definite)."""
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
            d = rank_step(lu, g, condensation)
            return (d if np.all(np.isfinite(d)) and g @ d < 0 else None), i + 1
    return None, len(SHIFTS)


def secant_step(lu, pairs, g) -> np.ndarray:
    """-H^-1 g (n_free,) with H^-1 the factorisation ``lu``'s inverse (anything with a
    ``solve``, e.g. a :class:`Factorised` with its rank-k term) updated by BFGS
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


def condensed_step(fac: Factorised, newton: Direction, condensation: Condensation | None) -> np.ndarray:
    """The condensed step dq = d_newton + S psi(e) (module docstring).

    Parameters
    ----------
    fac : Factorised
        The factorisation (may be from an earlier iterate: a chord step).
    newton : Direction
        The step d_newton = -H^-1 g of that factorisation (:meth:`Factorised.direction`
        of -g), m.
    condensation : Condensation or None
        The condensation where the step starts.

    Returns
    -------
    ndarray, shape (n_free,)
        The step, m; d_newton itself without a condensation or if the equation for e
        does not settle.
    """
    if condensation is None or fac.A is None:
        return newton.d
    law, stretch, C, K = condensation.law, condensation.stretch, fac.C, fac.K
    tau = condensation.at_stretch()[1]
    e_newton = newton.along_A()
    e = e_newton.copy()
    tol = 1e-12 * max(float(np.max(np.abs(e_newton))), condensation.scale)
    eye = np.eye(len(e))
    for _ in range(50):
        _, tau_e, k_e = law(stretch + e)
        de = np.linalg.solve(eye - C * (K - k_e), e_newton - e + C @ (tau + K * e - tau_e))
        e += de
        size = float(np.max(np.abs(de)))  # nan where de is not finite
        if size <= tol:
            return newton.plus_S(tau + K * e - law(stretch + e)[1])
        if not math.isfinite(size):
            break
    return newton.d


def reused_sensitivity(fem: ArmFEM, fac: Factorised, q, u, condensation, refine_du=None) -> np.ndarray:
    """dq/du at an equilibrium from the factorisation of a nearby iterate.

    dq/du = -H^-1 d2E/dq du. Along the condensation, d2E/dq du = A (gain K) and
    H = H_f + A (K - K_f) A^T, so the law's stiffness change is exact (Woodbury: a k x k
    solve); the inputs of other actuators take their mixed derivative through the same
    corrected solve. Along each direction du, v = dq/du du is then refined by conjugate
    gradients on H v = -d2E/dq du du, preconditioned with that, with exact Hessian
    products at q (:meth:`lab.fem.model.ArmFEM.hessian_operator`): three products and two
    solves.

    Parameters
    ----------
    fem : ArmFEM
        The model.
    fac : Factorised
        The factorisation of a nearby iterate.
    q : ndarray, shape (n_free,)
        The equilibrium, m.
    u : ndarray, shape (n_inputs,)
        Its inputs.
    condensation : Condensation or None
        The condensation at ``q``.
    refine_du : array_like, shape (k, n_inputs), optional
        Input steps along which dq/du is made accurate (~1e-4).

    Returns
    -------
    ndarray, shape (n_free, n_inputs)
        dq/du, m per unit of each input.
    """
    n_u = fem.n_inputs
    cols = slice(0, 0) if condensation is None else condensation.inputs
    condensed = set(np.arange(n_u)[cols].tolist())  # cols: a slice or the inputs' indices
    other = [j for j in range(n_u) if j not in condensed]
    if condensation is not None:
        A = condensation.A
        K = condensation.at_stretch()[2]
        dK = K - fac.K
        W = np.linalg.inv(np.eye(len(K)) + dK[:, None] * fac.C)

        def precondition(R):
            Z = fac.lu.solve(R)
            return Z - fac.S @ (W @ (dK * (fac.A.T @ Z)))

        r_K = condensation.gain * K
        D = -fac.S @ (W * r_K[None, :])
    else:
        precondition = fac.lu.solve
    if other:
        B = fem.mixed_derivative(q, u)[:, other]
        D_all = np.zeros((len(q), n_u))
        if condensation is not None:
            D_all[:, cols] = D
        D_all[:, other] = -np.column_stack([precondition(b) for b in B.T])
        D = D_all

    def forcing(du):  # d2E/dq du du
        f = A @ (r_K * du[cols]) if condensation is not None else 0.0
        return f + B @ du[other] if other else f

    U = []  # unit directions, none parallel
    for du in np.zeros((0, n_u)) if refine_du is None else np.atleast_2d(np.asarray(refine_du, float)):
        n = np.linalg.norm(du)
        if n > 0 and all(abs(du @ w) < (1 - 1e-9) * n for w in U):
            U.append(du / n)
    if not U:
        return D
    U = np.array(U)  # (k, n_u)
    V = np.empty((len(q), len(U)))
    hessian = fem.hessian_operator(q, u)
    for i, du in enumerate(U):
        v = D @ du
        r = -(hessian(v) + forcing(du))  # -(H v + d2E/dq du du)
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
