"""Static equilibrium x(u) = argmin_x E(x, u) by Newton's method, and its sensitivity.

Newton uses the exact Hessian; only when that does not give a descent direction (the
factorisation reports negative eigenvalues, or the step points uphill) is the elastic
part projected to positive semi-definite element by element, which is slower to
converge but always descends. A backtracking line search treats inverted elements as
infinite energy, with an Armijo slack of 1e-14 |E| so rounding does not reject the
last, converged steps. The final, convergence-confirming step reuses the previous
factorisation when that is accurate enough (see ``CHORD_CONTRACTION``).

Sensitivity analysis differentiates the equilibrium condition dE/dx (x(u), u) = 0:

    dx/du = -H^-1 d2E/dx du,     J_tip_u = S dx/du

with the *exact* Hessian H at the equilibrium (a projected one gives wrong Jacobians).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .fem import ArmFEM
from .linsolve import SingularMatrixError, factorize


#: The step that confirms convergence may reuse the last factorisation (a "chord" step)
#: when the previous step was already within CHORD_WINDOW tolerances: it is kept only
#: if it is below the tolerance and at most CHORD_CONTRACTION of the previous step
#: (Newton's quadratic convergence gives far less); otherwise the Hessian is
#: reassembled and refactorised as usual. Tried as a general modified-Newton step, the
#: chord step changed the path, wandered into indefinite regions and saved nothing.
CHORD_WINDOW = 100.0
CHORD_CONTRACTION = 0.25


class StaticSolveError(RuntimeError):
    """Newton did not reach equilibrium; ``.solution`` holds the last iterate."""

    def __init__(self, message: str, solution: "StaticSolution"):
        super().__init__(message)
        self.solution = solution


@dataclass
class StaticSolution:
    """Equilibrium for motor angles ``u_motor`` (m,) rad: free coordinates ``q``
    (n_free,), tip ``p_tip_W`` (3,) m, and how Newton got there."""
    u_motor: np.ndarray
    q: np.ndarray
    p_tip_W: np.ndarray
    converged: bool
    status: str
    iterations: int
    grad_norm_n: float
    projected_steps: int
    time_s: float
    factorizations: int = 0          # Hessian assemblies + factorisations (iterations = all steps)
    dq_du: np.ndarray | None = field(default=None, repr=False)
    J_tip_u: np.ndarray | None = field(default=None, repr=False)


def solve_static(fem: ArmFEM, u_motor, q0: np.ndarray | None = None, *, tol_step_m: float = 1e-7,
                 tol_force_n: float | None = None, max_iter: int = 60, sensitivity: str | bool = False,
                 raise_on_failure: bool = True, check_command: bool = True) -> StaticSolution:
    """Minimise E(q, u) from ``q0`` (default: rest). Returns the equilibrium.

    Converged when the Newton (or well-contracting chord) step with the exact Hessian
    moves no coordinate more than ``tol_step_m`` (m); that step is taken and ends the solve. Newton converges
    quadratically there, so the error left after that step is orders of magnitude
    below it. This test is independent of the load scale (a force tolerance is not:
    nodal gravity forces are ~1e-5 N on the default mesh). It also stops when the
    largest residual force is below ``tol_force_n`` (default 1e-5 of the largest nodal
    weight, at least 1e-11 N), where rounding can keep a nearly singular cable direction from settling.
    ``sensitivity``: ``True``/``"exact"`` also computes ``dq_du`` (n_free, m) and
    ``J_tip_u`` (3, m) in m/rad with a fresh factorisation at the equilibrium;
    ``"reuse"`` solves with the last factorisation instead (a step or two away from
    the equilibrium: accurate to the size of those steps, cheap; used for warm-start
    predictors). ``iterations`` counts all steps, ``factorizations`` the assemblies.
    Raises :class:`StaticSolveError` on failure unless ``raise_on_failure=False``, in
    which case the returned solution has ``converged=False`` and a ``status`` saying why.
    """
    t0 = time.perf_counter()
    u = fem.robot.check_command(u_motor) if check_command else np.asarray(u_motor, float)
    q = fem.rest_q() if q0 is None else np.array(q0, dtype=float)
    E = fem.energy(q, u)
    if not np.isfinite(E):
        raise ValueError("initial state has inverted elements; start from rest (q0=None)")
    if tol_force_n is None:
        tol_force_n = max(1e-5 * float(np.abs(fem.f_gravity_W).max()), 1e-11)
    status, projected, it, n_fact, lu, step_prev = "max_iter", 0, 0, 0, None, np.inf
    g = fem.gradient(q, u)
    while it < max_iter:
        if np.max(np.abs(g)) <= tol_force_n:
            status = "converged"
            break
        it += 1
        d, exact, chord = None, True, False
        if lu is not None and not lu.n_negative and step_prev <= CHORD_WINDOW * tol_step_m:
            # Last step: confirm convergence with the previous factorisation (one solve
            # instead of an assembly and a factorisation). Kept only if it is already
            # below the tolerance and contracts like Newton; otherwise refactorise.
            d = -lu.solve(g)
            step = np.max(np.abs(d))
            chord = bool(np.isfinite(step) and g @ d < 0 and step <= tol_step_m
                         and step <= CHORD_CONTRACTION * step_prev)
            d = d if chord else None
        if d is None:
            n_fact += 1
            try:
                lu = factorize(fem.hessian(q, u))
                if not lu.n_negative:
                    d = -lu.solve(g)
            except SingularMatrixError:
                lu = None
            if d is None or not np.all(np.isfinite(d)) or g @ d >= 0:
                projected, exact, lu = projected + 1, False, None
                d = -factorize(fem.hessian(q, u, project=True)).solve(g)
        step = float(np.max(np.abs(d)))
        if exact and step <= tol_step_m:
            # Converged: take the step without a line search, whose energy test cannot
            # resolve such small decreases (gravity sums terms ~1e-2 J) and would stall.
            q = q + d
            g = fem.gradient(q, u)
            status = "converged"
            break
        slope = g @ d
        alpha, accepted = 1.0, False
        for _ in range(1 if chord else 40):
            q_try = q + alpha * d
            E_try = fem.energy(q_try, u)
            if E_try <= E + 1e-4 * alpha * slope + 1e-14 * abs(E):
                accepted = True
                break
            alpha *= 0.5
        if not accepted:
            if chord:          # the old factorisation no longer fits: refactorise here
                step_prev = 0.0
                continue
            status = "line_search_failed"
            break
        q, E, step_prev = q_try, E_try, alpha * step
        g = fem.gradient(q, u)
    else:
        if np.max(np.abs(g)) <= tol_force_n:
            status = "converged"
    x = fem.to_nodes(q)
    sol = StaticSolution(u, q, fem.tip(x), status == "converged", status, it,
                         float(np.max(np.abs(g))), projected, 0.0, factorizations=n_fact)
    if sensitivity and sol.converged:
        if sensitivity == "reuse" and lu is not None and not lu.n_negative:
            sol.dq_du = -lu.solve(fem.mixed_derivative(q, u))
            sol.J_tip_u = fem.tip_matrix() @ sol.dq_du
        else:
            sol.dq_du, sol.J_tip_u = sensitivities(fem, q, u)
    sol.time_s = time.perf_counter() - t0
    if not sol.converged and raise_on_failure:
        raise StaticSolveError(
            f"static solve for u={u.tolist()} failed ({status}) after {it} iterations, "
            f"residual force {sol.grad_norm_n:.3g} N", sol)
    return sol


def sensitivities(fem: ArmFEM, q: np.ndarray, u_motor) -> tuple[np.ndarray, np.ndarray]:
    """dq/du (n_free, m) and the tip Jacobian J_tip_u = dp_tip/du (3, m) at an equilibrium."""
    lu = factorize(fem.hessian(q, u_motor))
    dq_du = -lu.solve(fem.mixed_derivative(q, u_motor))
    return dq_du, fem.tip_matrix() @ dq_du
