"""The Levenberg-Marquardt loop of :func:`lab.transfer.calibrate`, and the loop it replaced (the reference).

Both minimise C(theta) = |r(theta)|^2 + |(theta - theta0) / s|^2 (r the whitened misfit of
every sample, :mod:`lab.transfer.calibrate`) with steps h from (A + lam diag(A)) h = -b,
A = J^T J + diag(s)^-2, b = J^T r + (theta - theta0) / s^2; each trial step re-solves every
sample (:class:`lab.transfer.samples.Samples`), which is what a fit costs.

``"fast"`` (the default) takes the reference's steps with the reference's damping (so it
follows the same path to the same optimum: the fits are not convex, and other damping rules
tried, More's trust region among them, led some family members to another local optimum), but
spends less on them:

* a trial stops solving once the samples solved so far and the prior already cost more than
  C(theta): it would be rejected anyway. Samples go in the order the linear model expects them
  to miss most, after a rejection those that missed their prediction most first (a rejected
  step is followed by a nearly parallel one, which the same samples reject);
* converged when the proposed undamped step moves no parameter more than ``tol`` prior std:
  the fit stops there without solving that step (the reference solves it, then stops); a
  damped step below ``tol`` is solved and taken, then the fit stops, as the reference does;
* near the optimum (steps below :data:`TAIL` prior std), where the Gauss-Newton steps shrink
  only linearly (by 0.4 to 0.6 a step on some family members: J^T J misses
  sum_i r_i d2r_i/dtheta2), a secant estimate of that term (J. E. Dennis, D. M. Gay and
  R. E. Welsch's structured update, as NL2SOL) joins the step when it predicted the last
  step's cost better than Gauss-Newton did;
* each sample's sensitivities come from its solve's own factorisation where that is near
  (``Samples(reuse=True)``, :func:`lab.fem.solve.nearby.nearby_sensitivities`; J the same to
  round-off, dq/dtheta a predictor).

``"marquardt"``: the loop as it was (lam divided by 3 after an accepted step, multiplied by 4
after a rejected one; every trial solves every sample; fresh sensitivities after each accepted
step). It stays selectable as the reference of the tests and of
``benchmarks/bench_calibrate_speed.py``. How the two compare: docs/design/transfer.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lab.errors import InputError

__all__ = ["ALGORITHMS", "LMRun", "minimise"]

#: A trial stops once its solved samples miss what the linear model expected of them by this
#: many times the gain it expected of the whole step (the rest would have to beat their
#: predictions by half that gain for the step to be accepted, which the reference never saw).
MARGIN = 1.5
#: Below this largest step (prior std) the fit is near its optimum: the secant term may join.
TAIL = 0.05
#: The loops :func:`minimise` runs: the default first, then the reference.
ALGORITHMS = ("fast", "marquardt")


@dataclass
class LMRun:
    """Where :func:`minimise` stopped.

    Attributes
    ----------
    theta : numpy.ndarray
        The parameters, shape (p,).
    cost : float
        C(theta), dimensionless.
    q : numpy.ndarray
        The samples' equilibria at theta, shape (N, n_free), m.
    tips : numpy.ndarray
        The observed markers at theta, shape (N, 3K), m.
    J : numpy.ndarray
        Their Jacobian, shape (N, 3K, p), m per unit of each parameter.
    iterations : int
        Accepted steps (the reference also counts its last, failed attempt).
    converged : bool
        Whether the last (or a proposed) step was below ``tol`` prior std.
    trials, rejected : int
        Trial steps evaluated, and those rejected.
    history : list of dict
        One entry per iteration (``iteration``, ``rms_m``, ``cost``, ``max_step_over_prior_std``).
    """

    theta: np.ndarray
    cost: float
    q: np.ndarray
    tips: np.ndarray
    J: np.ndarray
    iterations: int
    converged: bool
    trials: int
    rejected: int
    history: list = field(default_factory=list, repr=False)


def minimise(samples, y, theta0, s, noise_m, start, *, max_iter=30, tol=1e-3, log=None, what="tip", algorithm=None):
    """Levenberg-Marquardt from theta0 (module docstring).

    Parameters
    ----------
    samples : Samples
        The samples (:class:`lab.transfer.samples.Samples`; ``reuse`` for ``"fast"``).
    y : numpy.ndarray
        Observed markers, shape (N, 3K), m.
    theta0 : numpy.ndarray
        The prior mean and starting point, shape (p,).
    s : numpy.ndarray
        Prior standard deviations, shape (p,).
    noise_m : float
        Declared noise, m per coordinate.
    start : tuple
        At theta0: q (N, n_free) m, tips (N, 3K) m, dq/dtheta (N, n_free, p) and J (N, 3K, p).
    max_iter : int
        Most accepted steps.
    tol : float
        Convergence: largest step, in prior standard deviations.
    log : callable, optional
        Called with a line per iteration.
    what : str
        ``"tip"`` or ``"marker"``, for the log.
    algorithm : str, optional
        One of :data:`ALGORITHMS` (default the first).

    Returns
    -------
    LMRun
        The optimum and how the loop got there.
    """
    algorithm = ALGORITHMS[0] if algorithm is None else algorithm
    if algorithm not in ALGORITHMS:
        raise InputError(f"algorithm must be one of {list(ALGORITHMS)}, got {algorithm!r}")
    q, tips, dq, J = start

    def cost(theta, tips):
        return float(np.sum((tips - y) ** 2) / noise_m**2 + np.sum(((theta - theta0) / s) ** 2))

    run = LMRun(theta0.copy(), cost(theta0, tips), q, tips, J, 0, False, 0, 0)
    run.history.append({"iteration": 0, "rms_m": _rms(tips - y), "cost": run.cost})
    loop = _fast if algorithm == "fast" else _marquardt
    loop(run, samples, y, theta0, s, noise_m, dq, cost, max_iter, tol, lambda step: _record(run, step, y, s, log, what))
    return run


def _normal_equations(run, y, theta0, s, noise_m):
    Jd = run.J.reshape(-1, len(s)) / noise_m
    A = Jd.T @ Jd + np.diag(1 / s**2)
    b = Jd.T @ ((run.tips - y).ravel() / noise_m) + (run.theta - theta0) / s**2
    return A, b


def _marquardt(run, samples, y, theta0, s, noise_m, dq, cost, max_iter, tol, record):
    """The reference loop (module docstring), as it was."""
    lam = 1e-3
    while run.iterations < max_iter and not run.converged:
        run.iterations += 1
        A, b = _normal_equations(run, y, theta0, s, noise_m)
        while True:
            step = np.linalg.solve(A + lam * np.diag(np.diag(A)), -b)
            trial = run.theta + step
            got = samples.solve(trial, run.q + dq @ step)
            run.trials += 1
            if got is not None and (c_trial := cost(trial, got[1])) < run.cost:
                break
            run.rejected += 1
            lam *= 4.0
            if lam > 1e10:
                break
        if lam > 1e10:  # no step decreases the cost: at the minimum to rounding
            run.converged = True
            break
        lam = max(lam / 3.0, 1e-9)
        run.theta, run.cost, (run.q, run.tips) = trial, c_trial, got
        dq, run.J = samples.sensitivities(run.theta, run.q)
        run.converged = bool(np.max(np.abs(step) / s) < tol)
        record(step)


def _fast(run, samples, y, theta0, s, noise_m, dq, cost, max_iter, tol, record):
    """The reference's steps and damping, trials stopped early, the secant term in the tail,
    no solve of a last step below the tolerance (module docstring)."""
    lam, S, suspects = 1e-3, np.zeros((len(s), len(s))), np.zeros(0, int)
    A, b = _normal_equations(run, y, theta0, s, noise_m)
    steps = _Steps(A, b)
    while True:
        step = steps(lam) if steps.augmented else np.linalg.solve(A + lam * np.diag(np.diag(A)), -b)
        small = np.max(np.abs(step) / s) < tol
        if small and steps.undamped(lam):  # the undamped step is below the tolerance
            run.converged = True
            return
        if run.iterations >= max_iter:
            return
        trial = run.theta + step
        predicted = run.tips + run.J @ step  # (N, 3K): the linear model
        prior = float(np.sum(((trial - theta0) / s) ** 2))
        expected = np.sum((predicted - y) ** 2, axis=1)  # m^2 per sample
        model = float(np.sum(expected)) / noise_m**2 + prior  # Gauss-Newton's
        curvature = float(step @ S @ step)  # what the secant term adds to it
        limit = (run.cost - prior) * noise_m**2  # m^2 of misfit the samples may add up to
        change = np.abs(expected - np.sum((run.tips - y) ** 2, axis=1))  # what the model expects to move
        rest = np.setdiff1d(np.arange(len(y)), suspects, assume_unique=True)
        order = np.concatenate([suspects, rest[np.argsort(-change[rest], kind="stable")]])
        start = run.q + dq @ step
        got = (
            samples.solve(trial, start, y=y, limit=limit, order=order, expected=expected, margin=MARGIN)
            if limit > 0
            else None
        )
        run.trials += 1
        if got is None:
            run.rejected += 1
            if limit > 0:  # next, first the samples that missed their prediction most
                missed = samples.misfits_m2 - expected
                worse = np.flatnonzero(missed > 0)  # (NaN, not solved, compares False)
                suspects = worse[np.argsort(-missed[worse], kind="stable")]
            lam *= 4.0
            if lam > 1e10:  # no step decreases the cost: at the minimum to rounding
                run.converged = True
                return
            continue
        c_trial = cost(trial, got[1])
        lam, suspects = max(lam / 3.0, 1e-9), np.zeros(0, int)
        # the model for the next step: the one that predicted this step's cost better
        augmented = abs(c_trial - model - curvature) < abs(c_trial - model)
        r_old, J_old = (run.tips - y).ravel() / noise_m, run.J.reshape(-1, len(s)) / noise_m
        run.theta, run.cost, run.q, run.tips, dq, run.J = trial, c_trial, *got
        run.iterations += 1
        record(step)
        if small:  # a damped step below the tolerance, taken (as the reference does)
            run.converged = True
            return
        A, b = _normal_equations(run, y, theta0, s, noise_m)
        r_new, J_new = (run.tips - y).ravel() / noise_m, run.J.reshape(-1, len(s)) / noise_m
        S = _secant_update(S, step, (J_new - J_old).T @ r_new, J_new.T @ r_new - J_old.T @ r_old + step / s**2)
        steps = _Steps(A, b)
        if augmented and np.max(np.abs(steps(lam)) / s) < TAIL:  # near the optimum: the secant term
            steps = _Steps(A, b, S)


def _secant_update(S, h, y_sharp, y):
    """The structured secant update of S ~ sum_i r_i d2r_i/dtheta2, the part of the Hessian
    of C / 2 that Gauss-Newton leaves out (J. E. Dennis, D. M. Gay and R. E. Welsch, "An
    adaptive nonlinear least-squares algorithm", ACM TOMS 7, 1981): sized down towards the
    secant condition, then the symmetric rank-2 change with S_new h = ``y_sharp``
    ((J_new - J_old)^T r_new), weighted by ``y`` (the change of the whole gradient).
    Skipped where y^T h <= 0."""
    yh = float(y @ h)
    if not yh > 0:
        return S
    hSh = float(h @ S @ h)
    if abs(hSh) > 0:
        S = S * min(1.0, abs(float(h @ y_sharp)) / abs(hSh))
    e = y_sharp - S @ h
    return S + (np.outer(e, y) + np.outer(y, e)) / yh - float(e @ h) * np.outer(y, y) / yh**2


class _Steps:
    """The steps h(lam) = -(A + S + lam diag(A))^-1 b of one iterate for any damping lam, from
    one eigendecomposition of the scaled matrix (p x p). The secant term S (None: Gauss-Newton)
    is dropped where it makes A + S indefinite (``augmented`` says whether it is in)."""

    def __init__(self, A, b, S=None):
        self.d = np.sqrt(np.diag(A))
        dd = np.outer(self.d, self.d)
        self.w, self.V = np.linalg.eigh(A / dd)
        self.augmented = False
        if S is not None:
            w, V = np.linalg.eigh((A + S) / dd)
            if w[0] > 1e-3 * self.w[0]:
                self.w, self.V, self.augmented = w, V, True
        self.c = self.V.T @ (b / self.d)

    def __call__(self, lam: float) -> np.ndarray:
        return -(self.V @ (self.c / (self.w + lam))) / self.d

    def undamped(self, lam: float) -> bool:
        """Whether ``lam`` changes the step by less than about 1 % (Gauss-Newton's step)."""
        return lam <= 1e-2 * self.w[0]


def _record(run, step, y, s, log, what):
    rms = _rms(run.tips - y)
    largest = float(np.max(np.abs(step) / s))
    run.history.append(
        {"iteration": run.iterations, "rms_m": rms, "cost": run.cost, "max_step_over_prior_std": largest}
    )
    if log:
        log(f"iteration {run.iterations}: RMS {what} misfit {1e3 * rms:.3f} mm, largest step {largest:.2g} prior std")


def _rms(residuals: np.ndarray) -> float:
    """RMS 3-D misfit per observed point of residuals (N, 3K), m."""
    r = np.asarray(residuals)
    return float(np.sqrt(np.mean(np.sum(r.reshape(-1, 3) ** 2, axis=1))))
