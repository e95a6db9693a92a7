"""Static equilibrium x(u) = argmin_x E(x, u) by Newton's method, and its sensitivity.

Newton uses the exact Hessian in condensed steps (:mod:`lab.fem.solve.steps`: the actuators'
:class:`~lab.fem.actuators.Condensation`, e.g. the cables' stretches); where it is
indefinite, a diagonally shifted one; only if that gives no descent direction either is the
elastic part projected to PSD element by element (always descends, but slow and expensive).
A backtracking line search treats inverted elements as infinite energy and rejects a step
that shrinks any element below ``MIN_VOLUME_RATIO`` of its volume, with an Armijo slack of
1e-14 |E| so rounding does not reject the last, converged steps; far from the equilibrium
and from a solve's third step on, where the law's evaluation is costly (the hyperfoam's), its
full-length trial assembles the next step's Hessian in the same pass over the tets
(``FUSED_TRIALS``). Near the equilibrium, chord steps reuse the last factorisation with
secant updates while they contract well (``CHORD_WINDOW``).

Sensitivity analysis differentiates the equilibrium condition dE/dx (x(u), u) = 0:

    dx/du = -H^-1 d2E/dx du,     J_tip_u = S dx/du   (m/rad)

with the *exact* Hessian H at the equilibrium (a projected one gives wrong Jacobians).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from lab.errors import InputError, LabRuntimeError
from lab.fem.model import ArmFEM
from lab.fem.solve.linsolve import factorize
from lab.fem.solve.steps import (
    condensed_factorisation,
    condensed_step,
    hessian_inputs,
    newton_step,
    rank_step,
    reused_sensitivity,
    secant_step,
    shifted_step,
)

#: A step may reuse the last factorisation (a "chord" step: one solve instead of an
#: assembly and a factorisation, BFGS-updated with the secant pairs of the steps taken
#: since, ``lab.fem.solve.steps.secant_step``) when the previous step was within CHORD_WINDOW
#: tolerances (1e-3 m by default); it is kept only if it is at most CHORD_CONTRACTION
#: of the previous step and passes the line search at full length, otherwise the
#: Hessian is reassembled and refactorised where the chord step started. (Chord steps
#: without that contraction test, far from the equilibrium, changed the path, wandered
#: into indefinite regions and saved nothing.) A chord step ends the solve only if,
#: besides being below the tolerance, the error it leaves, estimated from the
#: contraction of two successive steps as step * ratio / (1 - ratio), is below
#: CHORD_FINAL tolerances (tip errors ~1e-9 m on the grid, as with Newton alone). The
#: arm's softest bending mode (~0.015 N/m at rest) stiffens or softens by tens of %
#: within 10 um, so the first chord step after a distant factorisation says little
#: about the next one: that estimate needs two chord steps, or a factorisation within
#: 100 tolerances.
CHORD_WINDOW = 1e4
CHORD_CONTRACTION = 0.4
CHORD_FINAL = 1e-3

#: A line-search trial that leaves any element with less than this fraction of its current
#: volume is rejected, as an inverted one is. From rest, the first full Newton step of a
#: foam arm crushed the elements beside a cable's eyelets to 0.46-0.68 of their volume,
#: where the hyperfoam's Hessian is truly indefinite: the next steps needed the PSD
#: projection (32 projected steps on 75 solves of a foam member). Shorter steps around
#: that corner reach the same equilibrium without it, and in fewer factorisations
#: (``docs/fem-cost.md``).
MIN_VOLUME_RATIO = 0.8

#: Where a full-length trial step lies beyond CHORD_WINDOW tolerances, the next step will
#: assemble and factorise if the trial is accepted, so the line search can evaluate the
#: energy, gradient and Hessian there in one pass over the tets (``ArmFEM.energy(...,
#: with_hessian=True)``); a trial the line search rejects wastes that Hessian. At full length
#: a solve's first step overshot in 27 of 30 cold solves measured (three-cable, six-cable and
#: foam arms: the tangent at rest under a large command), its second in 17 of 30, a later one
#: in 56 of 250; so only from the third step on, and only where the law's evaluation is
#: costly beside its Hessian (:attr:`lab.fem.model.ArmFEM.trial_hessians_pay`). False: one
#: pass for the energy and gradient, another for the Hessian (the same numbers).
FUSED_TRIALS = True


class StaticSolveError(LabRuntimeError):
    """Newton did not reach equilibrium; ``.solution`` holds the last iterate.

    Parameters
    ----------
    message : str
        What failed, with the inputs and the residual force.
    solution : StaticSolution
        The last iterate (``converged`` False).
    """

    def __init__(self, message: str, solution: StaticSolution):
        super().__init__(message)
        self.solution = solution


@dataclass
class StaticSolution:
    """Equilibrium for inputs ``u_motor`` (m,) (the cables' motor angles in rad):
    free coordinates ``q`` (n_free,) m, tip ``p_tip_W`` (3,) m, and how Newton got there.

    Attributes
    ----------
    u_motor : ndarray, shape (m,)
        The m inputs, in the actuators' units (rad for the cables).
    q : ndarray, shape (n_free,)
        Free coordinates at the equilibrium (node positions in frame W), m.
    p_tip_W : ndarray, shape (3,)
        The tip marker in frame W, m.
    converged : bool
        Whether the solve met its tolerance.
    status : str
        ``"converged"``, ``"max_iter"``, ``"line_search_failed"`` or ``"indefinite"``.
    iterations : int
        Steps taken (Newton and chord).
    grad_norm_n : float
        Largest residual force at ``q``, N.
    projected_steps : int
        Steps with the PSD-projected Hessian (where shifts did not make it definite).
    time_s : float
        Wall time of the solve, s.
    factorizations : int
        Factorisations of a Hessian (a rejected line-search trial's Hessian, never
        factorised, is not counted).
    dq_du : ndarray, shape (n_free, m), optional
        dq/du if asked, m per unit of input.
    J_tip_u : ndarray, shape (3, m), optional
        d p_tip / du if asked, m per unit of input (m/rad for the cables).
    y_W : ndarray, shape (K, 3)
        Every marker (:attr:`lab.fem.ArmFEM.marker_names`, the tip first) in frame W, m.
    J_y_u : ndarray, shape (3K, m), optional
        d y / du of the ravelled markers if asked, m per unit of input.
    factorisation : tuple, optional
        If asked (``keep_factorisation``) and converged: the last exact factorisation
        (``Factorised``, of a Newton iterate near ``q``; None after
        shifted or projected steps), the condensation at ``q`` and how far ``q`` lies from
        that iterate (largest coordinate, m), for :mod:`lab.fem.solve.nearby`.
    """

    u_motor: np.ndarray
    q: np.ndarray
    p_tip_W: np.ndarray
    converged: bool
    status: str
    iterations: int
    grad_norm_n: float
    projected_steps: int
    time_s: float
    factorizations: int = 0  # Hessian assemblies + factorisations (iterations = all steps)
    dq_du: np.ndarray | None = field(default=None, repr=False)
    J_tip_u: np.ndarray | None = field(default=None, repr=False)
    y_W: np.ndarray | None = field(default=None, repr=False)
    J_y_u: np.ndarray | None = field(default=None, repr=False)
    factorisation: tuple | None = field(default=None, repr=False)


def solve_static(
    fem: ArmFEM,
    u_motor,
    q0: np.ndarray | None = None,
    *,
    tol_step_m: float = 1e-7,
    tol_force_n: float | None = None,
    max_iter: int = 60,
    sensitivity: str | bool = False,
    raise_on_failure: bool = True,
    check_command: bool = True,
    refine_du=None,
    stop_if_indefinite: bool = False,
    keep_factorisation: bool = False,
) -> StaticSolution:
    """Minimise E(q, u) from ``q0`` (default: rest). Returns the equilibrium.

    Converged when the (condensed) Newton step with the exact Hessian, or a chord
    step that contracts well (see ``CHORD_FINAL``), moves no coordinate more than
    ``tol_step_m`` (m); that step is taken and ends the solve. Newton converges
    quadratically there, so the error left after that step is orders of magnitude
    below it. This test is independent of the load scale (a force tolerance is not:
    nodal gravity forces are ~1e-5 N on the default mesh). It also stops when the
    largest residual force is below ``tol_force_n`` (default 1e-5 of the largest nodal
    weight, at least 1e-11 N), where rounding can keep a nearly singular condensed
    direction (a cable's) from settling; not after a chord step, whose error that force bound does
    not bound well enough along the soft bending mode (~1e-8 m on a coarse mesh).
    ``sensitivity``: ``True``/``"exact"`` also computes ``dq_du`` (n_free, m) and
    ``J_tip_u`` (3, m) in m/rad with a fresh factorisation at the equilibrium;
    ``"reuse"`` takes them from the last factorisation instead (no new one; a step or a
    few chord steps away from the equilibrium, up to ~1 mm: for predictors, off by up to
    ~20 % along the softest bending mode), made accurate (to ~1e-4) along the rows of
    ``refine_du`` (k, m) rad if given, the motor steps the caller will predict along
    (a few ms each).
    ``stop_if_indefinite``: return at once, with ``status="indefinite"``, if the exact
    Hessian at ``q0`` is not positive definite (one factorisation spent), for a caller
    that has other starting points to try first.
    ``keep_factorisation``: return the last exact factorisation with the equilibrium
    (``factorisation``), for sensitivities without a new one (:mod:`lab.fem.solve.nearby`).
    ``iterations`` counts all steps, ``factorizations`` the factorised Hessians (a shifted
    one counts once more).
    Raises :class:`StaticSolveError` on failure unless ``raise_on_failure=False``, in
    which case the returned solution has ``converged=False`` and a ``status`` saying why.

    Parameters
    ----------
    fem : ArmFEM
        The model.
    u_motor : array_like, shape (n_inputs,)
        The inputs of all its actuators (the cables' motor angles in rad, first).
    q0 : ndarray, shape (n_free,), optional
        Where to start, m; default rest.
    tol_step_m, tol_force_n : float
        Step (m) and residual force (N) tolerances (above).
    max_iter : int
        Most steps.
    sensitivity : bool or str
        False, True/``"exact"`` or ``"reuse"`` (above).
    raise_on_failure : bool
        Raise :class:`StaticSolveError` if it does not converge.
    check_command : bool
        Check the inputs with the actuators (:meth:`ArmFEM.check_input`) first.
    refine_du : array_like, shape (k, n_inputs), optional
        Input steps along which a reused dq/du is refined.
    stop_if_indefinite : bool
        Return at once where the exact Hessian at ``q0`` is indefinite.
    keep_factorisation : bool
        Keep the last exact factorisation in the solution's ``factorisation``.

    Returns
    -------
    StaticSolution
        The equilibrium (or the last iterate), with ``dq_du`` (n_free, n_inputs) and
        ``J_tip_u`` (3, n_inputs) if asked.
    """
    t0 = time.perf_counter()
    u = fem.check_input(u_motor) if check_command else np.asarray(u_motor, float)
    q = fem.rest_q() if q0 is None else np.array(q0, dtype=float)
    E, g, cond = fem.energy(q, u, with_gradient=True)
    if not np.isfinite(E):
        raise InputError("initial state has inverted elements; start from rest (q0=None)")
    if tol_force_n is None:
        tol_force_n = max(1e-5 * float(np.abs(fem.f_gravity_W).max()), 1e-11)
    status, projected, it, n_fact, fac, step_prev, q_fac = "max_iter", 0, 0, 0, None, np.inf, None
    chord = False
    pairs, H_next = [], None  # H_next: the Hessian at q, if the line search assembled it
    J = fem.volume_ratio(q)  # (M,) det F at q
    while it < max_iter:
        if np.max(np.abs(g)) <= tol_force_n and not chord:  # chord steps: see CHORD_FINAL
            status = "converged"
            break
        it += 1
        prev_chord = chord
        d, exact, chord = None, True, False
        if fac is not None and step_prev <= CHORD_WINDOW * tol_step_m:
            # Near convergence: a step with the previous factorisation. Kept only if it
            # contracts well (and, unless converged, passes the line search at full
            # length); otherwise refactorise here.
            if pairs:
                d = secant_step(fac, pairs, g)
            else:
                d = condensed_step(fac, fac.direction(-g), cond)
            step = np.max(np.abs(d))
            chord = bool(np.isfinite(step) and g @ d < 0 and step <= CHORD_CONTRACTION * step_prev)
            d = d if chord else None
        if d is None:
            n_fact += 1
            u_h = hessian_inputs(u, g, cond)  # u, but for a condensation not in the Hessian
            H = fem.hessian(q, u_h) if H_next is None else H_next
            d, fac = newton_step(H, g, cond)
            q_fac, pairs = q, []
            exact = d is not None
            if not exact and stop_if_indefinite and it == 1:
                status = "indefinite"
                break
            if not exact:
                d, n_shifted = shifted_step(H, g, cond)
                n_fact += n_shifted
            if d is None:
                projected += 1
                d = rank_step(factorize(fem.hessian(q, u_h, project=True)), g, cond)
        step = float(np.max(np.abs(d)))
        if (
            exact
            and step <= tol_step_m
            and (
                not chord
                or (
                    (prev_chord or step_prev <= 100 * tol_step_m)  # a trustworthy ratio
                    and step * step / max(step_prev - step, 1e-300) <= CHORD_FINAL * tol_step_m
                )
            )
        ):
            # Converged: take the step without a line search, whose energy test cannot
            # resolve such small decreases (gravity sums terms ~1e-2 J) and would stall.
            q = q + d
            g, cond = fem.gradient(q, u, with_condensation=True)
            status = "converged"
            break
        slope, H_next = g @ d, None
        fuse = FUSED_TRIALS and it > 2 and fem.trial_hessians_pay and step > CHORD_WINDOW * tol_step_m
        fuse = fuse and (cond is None or cond.in_hessian)
        alpha, accepted = 1.0, False
        for _ in range(1 if chord else 40):
            q_try = q + alpha * d
            J_try = fem.volume_ratio(q_try)  # first: far cheaper than a foam's energy
            if np.all(J_try >= MIN_VOLUME_RATIO * J):
                if alpha == 1.0 and fuse:  # the next step's Hessian along (FUSED_TRIALS)
                    E_try, g_try, cond_try, H_next = fem.energy(q_try, u, with_hessian=True)
                elif alpha == 1.0:  # usually accepted: take its gradient along (shared kinematics)
                    E_try, g_try, cond_try = fem.energy(q_try, u, with_gradient=True)
                else:
                    E_try = fem.energy(q_try, u)
                if E_try <= E + 1e-4 * alpha * slope + 1e-14 * abs(E):
                    accepted = True
                    break
            alpha *= 0.5
        if not accepted:
            if chord:  # the old factorisation no longer fits: refactorise here
                step_prev = np.inf
                continue
            status = "line_search_failed"
            break
        q_old, g_old = q, g
        q, E, J, step_prev = q_try, E_try, J_try, alpha * step
        if alpha == 1.0:
            g, cond = g_try, cond_try
            if cond is not None and not cond.in_hessian:  # assembled at other inputs then
                H_next = None
        else:
            g, cond, H_next = *fem.gradient(q, u, with_condensation=True), None
        if fac is not None and (q - q_old) @ (g - g_old) > 0:  # secant pair for chord steps
            pairs.append((q - q_old, g - g_old, 1.0 / ((q - q_old) @ (g - g_old))))
    else:
        if np.max(np.abs(g)) <= tol_force_n:
            status = "converged"
    x = fem.to_nodes(q)
    sol = StaticSolution(
        u,
        q,
        fem.tip(x),
        status == "converged",
        status,
        it,
        float(np.max(np.abs(g))),
        projected,
        0.0,
        factorizations=n_fact,
    )
    sol.y_W = fem.observe(x)
    if keep_factorisation and sol.converged:
        sol.factorisation = (fac, cond, None if fac is None else float(np.max(np.abs(q - q_fac))))
    if sensitivity and sol.converged:
        if sensitivity == "reuse" and fac is not None:
            sol.dq_du = reused_sensitivity(fem, fac, q, u, cond, refine_du)
            sol.J_tip_u = fem.tip_matrix() @ sol.dq_du
        else:
            sol.dq_du, sol.J_tip_u = sensitivities(fem, q, u)
        sol.J_y_u = fem.marker_matrix() @ sol.dq_du
    sol.time_s = time.perf_counter() - t0
    if not sol.converged and raise_on_failure:
        raise StaticSolveError(
            f"static solve for u={u.tolist()} failed ({status}) after {it} iterations, "
            f"residual force {sol.grad_norm_n:.3g} N",
            sol,
        )
    return sol


def sensitivities(fem: ArmFEM, q: np.ndarray, u_motor) -> tuple[np.ndarray, np.ndarray]:
    """dq/du and the tip Jacobian at an equilibrium, from a fresh factorisation (of the
    exact Hessian; a condensation's rank-k term that it does not hold, a volume chamber's,
    added exactly by Woodbury, :class:`~lab.fem.solve.factorised.Factorised`).

    Parameters
    ----------
    fem : ArmFEM
        The model.
    q : ndarray, shape (n_free,)
        An equilibrium, m.
    u_motor : array_like, shape (n_inputs,)
        Its inputs.

    Returns
    -------
    dq_du : ndarray, shape (n_free, n_inputs)
        m per unit of each input (m/rad for the cables).
    J_tip_u : ndarray, shape (3, n_inputs)
        The tip marker's Jacobian dp_tip/du.
    """
    lu = factorize(fem.hessian(q, u_motor))
    M = fem.mixed_derivative(q, u_motor)
    cond = fem.gradient(q, u_motor, with_condensation=True)[1] if any(a.condenses for a in fem.actuators) else None
    if cond is None or cond.in_hessian:
        dq_du = -lu.solve(M)
    else:  # H + A K A^T by Woodbury (steps module docstring)
        fac, _ = condensed_factorisation(lu, np.zeros(len(q)), cond)
        dq_du = -fac.solve(M)
    return dq_du, fem.tip_matrix() @ dq_du
