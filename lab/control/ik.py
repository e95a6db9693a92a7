"""Inverse kinematics through a differentiable forward map (Sections II-A, II-C, II-D).

Given a target tip position ``y'`` (3,) m, find motor angles ``u`` (m,) rad in the
allowed set ``C`` (:class:`lab.control.command_set.CommandSet`: ``[0, u_max]`` and the robot's
safety rule) minimising Eq. (1) of the paper, plus an optional regulariser::

    O(u) = 1/2 |y(u) - y'|^2  +  w/2 |u - u_ref|^2,      dO/du = J^T (y - y') + w (u - u_ref)

``y(u)`` and ``J = dy/du`` (3, m) m/rad come from any object with
``predict_and_jacobian(u) -> (y (3,), J (3, m))``: the learned network
(:class:`lab.learn.mlp.MLP`, analytic network Jacobian) or the FEM with sensitivity
analysis (:class:`lab.control.soft_ik.FEMForwardMap`, "Soft IK"). ``w`` (m^2/rad^2, default 0)
pulls towards ``u_ref``.

Redundant robots (six cables, three tip coordinates) reach a target with a whole family of
commands, and :meth:`IKSolver.follow` uses ``u_ref`` to pick one along a trajectory:
``u_ref`` blends the previous command (weight ``reg_weight``: continuity) with a posture
``u_posture`` (weight ``posture_weight``: keeps the cables taut, away from the slack
plateaus where a cable's Jacobian column is zero and a warm start gets stuck). The
regulariser also pulls the tip off the target, so ``follow`` then *polishes*: a second,
unregularised solve from the regularised answer, which moves the command only a little
(the regulariser has already picked the branch of solutions) and removes that bias.

Two solvers, both keeping every iterate in ``C``:

* ``"gd"`` -- projected gradient descent, the paper's minimiser. Step rule: Armijo
  backtracking along the projection arc (Bertsekas): try ``u+ = P(u - a g)`` and accept
  when ``O(u+) <= O(u) + sigma g.(u+ - u)``, else halve ``a``. The first trial step of
  a solve is ``1 / L`` with ``L = |J|_F^2 + w`` (a bound on the Lipschitz constant of
  the Gauss-Newton model's gradient, as |J|_F >= |J|_2); each later one starts from
  twice the last accepted step, so the step adapts up and down. ``sigma = 0.5``
  (:data:`ARMIJO`): on a quadratic it accepts only steps up to the exact line minimum.
  The textbook 1e-4 lets the growing step settle near the stability edge 2/lambda_max,
  where the stiff direction zigzags: on the circle some targets then took 10,000+
  iterations instead of ~300. Converges linearly, slowly when ``J`` is ill-conditioned
  (iterations grow like cond(J)^2).
* ``"lm"`` -- bounded Levenberg-Marquardt: the step minimises the damped Gauss-Newton
  model ``g.d + 1/2 d^T (J^T J + w I + mu I) d`` over ``u + d in C`` exactly (a small QP,
  :meth:`CommandSet.solve_qp`; when the unconstrained step is feasible it is that step).
  It is accepted when the objective decreases; ``mu`` follows Nielsen's rule (shrinks
  after good steps, doubles-and-more after rejected ones). Quadratic convergence near a
  solution: a warm-started trajectory point takes 2-3 iterations.

Stopping (both): ``converged`` when the tip residual ``|y - y'|`` <= ``tol_m``;
``stationary`` when the projected gradient ``pg = L (u - P(u - g/L))`` is tiny compared
with what the residual would give if the motors could still reduce it,
``|pg| <= tol_stationary |J_r|_F |r|`` (``r`` the residual vector of ``O`` including the
regulariser rows, ``J_r`` its Jacobian; at a target in reach ``g = J^T r`` is at least
``|r| / cond(J)`` times that, so the test only fires at a constrained minimum that misses
the target: unreachable, or a local minimum); ``stalled`` when no decrease is possible
at rounding level; else ``max_iter``.
``reachable`` = residual <= ``reach_tol_m``. An unreachable target therefore returns the
best command found inside ``C`` (the local minimum of ``O`` nearest the start) with
``reachable=False`` and its residual; a NaN/inf target raises ValueError before any work.

Cold starts begin at the seed whose tip is nearest the target (``seeds``, e.g. the
training data or :func:`grid_seeds`), else at the projection of the box centre;
:meth:`IKSolver.follow` warm-starts each trajectory point from the previous solution
(Section II-D), and retries a point it misses from the nearest cold starts (a warm start can sit on
a slack cable's plateau, where that cable's Jacobian column is zero).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from lab.control.command_set import CommandSet
from lab.errors import InputError

METHODS = ("lm", "gd")
#: Sufficient-decrease constant of gradient descent's Armijo test (see the module docstring).
ARMIJO = 0.5


@dataclass
class IKResult:
    """One IK solve: command ``u_motor`` (m,) rad, predicted tip ``p_pred_W`` (3,) m, tip
    residual ``residual_m`` = |y(u) - y'| m, objective ``objective_m2``, how it stopped."""

    u_motor: np.ndarray
    p_pred_W: np.ndarray
    residual_m: float
    objective_m2: float
    reachable: bool
    status: str
    iterations: int
    evaluations: int
    time_s: float
    history_m: list = field(default_factory=list, repr=False)  # residual after each iteration


@dataclass
class TrajectoryIK:
    """IK along a trajectory of N targets: per-point arrays and the per-point results."""

    targets_W: np.ndarray  # (N, 3) m
    u_motor: np.ndarray  # (N, m) rad
    p_pred_W: np.ndarray  # (N, 3) m, forward map at u_motor
    residual_m: np.ndarray  # (N,) m
    reachable: np.ndarray  # (N,) bool
    iterations: np.ndarray  # (N,)
    time_s: np.ndarray  # (N,) s per target
    results: list = field(repr=False, default_factory=list)


def check_targets(targets) -> np.ndarray:
    """Targets as a float array (3,) or (N, 3) m; ValueError naming the problem otherwise."""
    t = np.asarray(targets, dtype=float)
    if t.shape[-1:] != (3,) or t.ndim not in (1, 2) or t.size == 0:
        raise InputError(f"targets must be (3,) or (N, 3) positions in metres, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        bad = np.argwhere(~np.isfinite(np.atleast_2d(t)))[0, 0]
        raise InputError(f"target {bad} is not finite: {np.atleast_2d(t)[bad].tolist()} (NaN or inf)")
    return t


def grid_seeds(forward, commands: CommandSet, levels: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Cold-start seeds: the allowed points of a ``levels``^m grid and their predicted tips
    (u (S, m) rad, y (S, 3) m). Needs a batched ``forward.predict`` (e.g. the network)."""
    axes = [np.linspace(lo, hi, levels) for lo, hi in zip(commands.lo, commands.hi)]
    u = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, commands.n)
    u = u[np.all(u @ commands.A.T <= commands.b + commands.tol, axis=1)]
    return u, np.asarray(forward.predict(u), dtype=float)


class IKSolver:
    """IK for one forward map and command set. ``method``: "lm" or "gd" (module docstring).

    ``tol_m``: stop when the tip residual is below this (m); ``reach_tol_m``: residual up to
    which a target counts as reached; ``tol_stationary``: relative stationarity tolerance;
    ``reg_weight``: ``w`` of the regulariser (m^2/rad^2); ``posture_weight``, ``u_posture``
    (default the centre of the allowed set) and ``polish``: how :meth:`follow` picks among
    redundant solutions (module docstring); ``retry_cold``: in :meth:`follow` without a
    regulariser, a point that misses its target is solved again from the nearest cold
    starts, and the best answer kept; ``seeds``: (u (S, m), y (S, 3))
    for cold starts. ``max_iter`` defaults to 100 (lm) or 20000 (gd). ``record_history``:
    keep the tip residual of every iterate in ``IKResult.history_m`` (for plots).
    """

    def __init__(
        self,
        forward,
        commands: CommandSet,
        method: str = "lm",
        *,
        tol_m: float = 1e-8,
        reach_tol_m: float = 1e-5,
        tol_stationary: float = 1e-6,
        max_iter: int | None = None,
        reg_weight: float = 0.0,
        posture_weight: float = 0.0,
        u_posture=None,
        polish: bool = True,
        retry_cold: bool = True,
        seeds=None,
        record_history: bool = False,
    ):
        if method not in METHODS:
            raise InputError(f"method must be one of {METHODS}, got {method!r}")
        for name, w in (("reg_weight", reg_weight), ("posture_weight", posture_weight)):
            if w < 0 or not np.isfinite(w):
                raise InputError(f"{name} must be finite and >= 0, got {w}")
        self.forward, self.commands, self.method = forward, commands, method
        self.tol_m, self.reach_tol_m = float(tol_m), float(reach_tol_m)
        self.tol_stationary = float(tol_stationary)
        self.max_iter = int(max_iter or (100 if method == "lm" else 20000))
        self.reg_weight, self.posture_weight = float(reg_weight), float(posture_weight)
        self.polish = bool(polish)
        self.retry_cold = bool(retry_cold)
        self.record_history = bool(record_history)
        self.seeds = None
        if seeds is not None:
            u_s, y_s = (np.asarray(a, dtype=float) for a in seeds)
            if u_s.ndim != 2 or u_s.shape[1] != commands.n or y_s.shape != (len(u_s), 3):
                raise InputError(f"seeds must be (u (S, {commands.n}), y (S, 3)), got {u_s.shape}, {y_s.shape}")
            self.seeds = (u_s, y_s)
        self.centre = commands.project(0.5 * (commands.lo + commands.hi))
        self.u_posture = self.centre.copy() if u_posture is None else np.asarray(u_posture, dtype=float)
        if self.u_posture.shape != (commands.n,) or not commands.contains(self.u_posture):
            raise InputError(f"u_posture must be an allowed command of {commands.n} angles, got {u_posture!r}")

    # ----------------------------------------------------------------- public API
    def initial_guess(self, target_W) -> np.ndarray:
        """Cold start for ``target_W`` (3,) m: nearest seed (projected into C) or the centre."""
        if self.seeds is None:
            return self.centre.copy()
        u_s, y_s = self.seeds
        return self.commands.project(u_s[int(np.argmin(np.sum((y_s - target_W) ** 2, axis=1)))])

    def solve(self, target_W, u0=None, u_ref=None, reg_weight: float | None = None) -> IKResult:
        """Solve for one target (3,) m from ``u0`` (m,) rad (default :meth:`initial_guess`),
        regularised towards ``u_ref`` (default ``u0``) with weight ``reg_weight`` (m^2/rad^2;
        default the solver's ``reg_weight``)."""
        target = check_targets(target_W)
        if target.ndim != 1:
            raise InputError(f"solve takes one target (3,), got {target.shape}; use follow() for many")
        t0 = time.perf_counter()
        u = self.initial_guess(target) if u0 is None else np.asarray(u0, dtype=float)
        if u.shape != (self.commands.n,) or not np.all(np.isfinite(u)):
            raise InputError(f"u0 must be {self.commands.n} finite angles in rad, got {u0!r}")
        u = self.commands.project(u)
        u_ref = u.copy() if u_ref is None else np.asarray(u_ref, dtype=float)
        if u_ref.shape != u.shape or not np.all(np.isfinite(u_ref)):
            raise InputError(f"u_ref must be {self.commands.n} finite angles in rad, got {u_ref!r}")
        run = self._lm if self.method == "lm" else self._gd
        keep, self.reg_weight = self.reg_weight, self.reg_weight if reg_weight is None else float(reg_weight)
        try:
            res = run(target, u, u_ref)
        finally:
            self.reg_weight = keep
        res.time_s = time.perf_counter() - t0
        return res

    def _retry_cold(self, target, first: IKResult, start, n_starts: int = 4) -> IKResult:
        """A miss may be a stuck start (a slack cable's plateau, zero Jacobian column; learned
        models of arms with slack have one near u = 0): retry from the ``n_starts`` seeds
        nearest the target (or the centre) but ``start``; keep the best, counting all work."""
        starts = [self.centre]
        if self.seeds is not None:
            u_s, y_s = self.seeds
            near = np.argsort(np.sum((y_s - target) ** 2, axis=1))[:n_starts]
            starts = [self.commands.project(u_s[i]) for i in near]
        tries = [first]
        for u0 in (u for u in starts if not np.allclose(u, start)):
            if tries[-1].reachable:
                break
            tries.append(self.solve(target, u0))
        best = min(tries, key=lambda r: r.residual_m)
        return _count_work(best, [r for r in tries if r is not best])

    def follow(self, targets_W, u0=None) -> TrajectoryIK:
        """IK for each of the targets (N, 3) m in order, warm-starting every point from the
        previous solution (the first from ``u0`` or a cold start). With ``reg_weight`` or
        ``posture_weight`` > 0 each point is first solved regularised towards
        ``(reg_weight u_prev + posture_weight u_posture) / (reg_weight + posture_weight)``
        (``u_prev``: the previous command; a cold first point is pulled to ``u_posture``
        alone, or to its cold start without a posture term), then, if
        ``polish``, solved again unregularised from there (module docstring); the result
        reports the iterations and time of both solves."""
        targets = np.atleast_2d(check_targets(targets_W))
        results, u_prev = [], u0
        w = self.reg_weight + self.posture_weight
        for target in targets:
            if w > 0:
                if u_prev is None:
                    # A cold first point has no previous command to stay near: only the
                    # posture pulls, so the path starts on the posture's branch instead of
                    # drifting onto it (in big steps) over the next points.
                    u_start, w_now = self.initial_guess(target), self.posture_weight or w
                    u_ref = self.u_posture if self.posture_weight > 0 else u_start
                else:
                    u_start, w_now = np.asarray(u_prev, dtype=float), w
                    u_ref = (self.reg_weight * u_start + self.posture_weight * self.u_posture) / w
                res = self.solve(target, u_start, u_ref=u_ref, reg_weight=w_now)
                if self.polish:
                    first, res = res, self.solve(target, res.u_motor, reg_weight=0.0)
                    res = _count_work(res, [first])
                    res.history_m = first.history_m + res.history_m
            else:
                res = self.solve(target, u_prev, u_ref=u_prev)
                if not res.reachable and self.retry_cold:
                    start = self.initial_guess(target) if u_prev is None else self.commands.project(u_prev)
                    res = self._retry_cold(target, res, start)
            results.append(res)
            u_prev = res.u_motor
        col = lambda name: np.array([getattr(r, name) for r in results])  # noqa: E731
        return TrajectoryIK(
            targets,
            col("u_motor"),
            col("p_pred_W"),
            col("residual_m"),
            col("reachable"),
            col("iterations"),
            col("time_s"),
            results,
        )

    # ----------------------------------------------------------------- internals
    def _evaluate(self, u, target, u_ref):
        """(y, J, objective) at u; objective is inf where the forward map gives no finite answer."""
        y, J = self.forward.predict_and_jacobian(u)
        y, J = np.asarray(y, dtype=float), np.asarray(J, dtype=float)
        if not (np.all(np.isfinite(y)) and np.all(np.isfinite(J))):
            return y, J, np.inf
        r = y - target
        return y, J, 0.5 * float(r @ r) + 0.5 * self.reg_weight * float(np.sum((u - u_ref) ** 2))

    def _gradient(self, u, y, J, target, u_ref):
        return J.T @ (y - target) + self.reg_weight * (u - u_ref)

    def _stationary(self, u, g, lipschitz, obj) -> bool:
        """Projected gradient small relative to |J_r|_F |r| (module docstring); lipschitz =
        |J|_F^2 + w, and |J_r|_F^2 = |J|_F^2 + m w <= m lipschitz bounds it from above."""
        pg = lipschitz * np.linalg.norm(u - self.commands.project(u - g / lipschitz, x0=u))
        return pg <= self.tol_stationary * np.sqrt(len(u) * lipschitz * 2.0 * obj)

    def _result(self, u, y, obj, target, status, it, n_eval, history) -> IKResult:
        res = float(np.linalg.norm(y - target))
        if status != "converged" and res <= self.tol_m:
            status = "converged"
        return IKResult(u, y, res, obj, res <= self.reach_tol_m, status, it, n_eval, 0.0, history)

    def _record(self, history, y, target) -> None:
        if self.record_history:
            history.append(float(np.linalg.norm(y - target)))

    def _first(self, u, target, u_ref):
        y, J, obj = self._evaluate(u, target, u_ref)
        if not np.isfinite(obj):
            raise InputError(f"the forward map gives no finite tip at the start command {u.tolist()} rad")
        return y, J, obj

    def _lm(self, target, u, u_ref) -> IKResult:
        y, J, obj = self._first(u, target, u_ref)
        w, n_eval, nu, mu, eye = self.reg_weight, 1, 2.0, None, np.eye(len(u))
        status, history = "max_iter", []
        self._record(history, y, target)
        for it in range(self.max_iter):  # noqa: B007 (it is the iteration count after the loop)
            if np.linalg.norm(y - target) <= self.tol_m:
                status = "converged"
                break
            g = self._gradient(u, y, J, target, u_ref)
            JtJ = J.T @ J + w * eye
            lip = float(np.sum(J * J)) + w
            if self._stationary(u, g, lip, obj):
                status = "stationary"
                break
            if mu is None:
                mu = 1e-3 * float(np.max(np.diag(JtJ)))
            H = JtJ + mu * eye
            d = -np.linalg.solve(H, g)
            if not self.commands.contains(u + d, 0.0):
                d = self.commands.solve_qp(H, g - H @ u, x0=u) - u
            predicted = -(g @ d + 0.5 * d @ JtJ @ d)
            if predicted <= 1e-30 or np.max(np.abs(d)) <= 1e-15 * self.commands.scale:
                status = "stalled"
                break
            u_new = u + d
            y_new, J_new, obj_new = self._evaluate(u_new, target, u_ref)
            n_eval += 1
            rho = (obj - obj_new) / predicted
            if rho > 0:  # accept: Nielsen's update
                u, y, J, obj = u_new, y_new, J_new, obj_new
                mu *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu = 2.0
                self._record(history, y, target)
            else:
                mu *= nu
                nu *= 2.0
                if mu > 1e20 * lip:
                    status = "stalled"
                    break
        else:
            it = self.max_iter
        return self._result(u, y, obj, target, status, it, n_eval, history)

    def _gd(self, target, u, u_ref) -> IKResult:
        y, J, obj = self._first(u, target, u_ref)
        n_eval, alpha, status, history = 1, None, "max_iter", []
        self._record(history, y, target)
        for it in range(self.max_iter):  # noqa: B007 (it is the iteration count after the loop)
            if np.linalg.norm(y - target) <= self.tol_m:
                status = "converged"
                break
            g = self._gradient(u, y, J, target, u_ref)
            lip = float(np.sum(J * J)) + self.reg_weight
            if self._stationary(u, g, lip, obj):
                status = "stationary"
                break
            a = 1.0 / lip if alpha is None else 2.0 * alpha
            for _ in range(60):  # Armijo along the projection arc
                u_new = self.commands.project(u - a * g, x0=u)
                y_new, J_new, obj_new = self._evaluate(u_new, target, u_ref)
                n_eval += 1
                if obj_new <= obj + ARMIJO * float(g @ (u_new - u)):
                    break
                a *= 0.5
            else:
                status = "stalled"
                break
            if np.array_equal(u_new, u):
                status = "stalled"
                break
            u, y, J, obj, alpha = u_new, y_new, J_new, obj_new, a
            self._record(history, y, target)
        else:
            it = self.max_iter
        return self._result(u, y, obj, target, status, it, n_eval, history)


def _count_work(result: IKResult, others) -> IKResult:
    """``result`` with the iterations, evaluations and time of the ``others`` solves added."""
    for other in others:
        result.iterations += other.iterations
        result.evaluations += other.evaluations
        result.time_s += other.time_s
    return result
