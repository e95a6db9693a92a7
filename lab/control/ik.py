"""Inverse kinematics through a differentiable forward map (Sections II-A, II-C, II-D).

Given a target tip position ``y'`` (3,) m, find motor angles ``u`` (m,) rad in the
allowed set ``C`` (:class:`lab.control.command_set.CommandSet`: ``[0, u_max]`` and the robot's
safety rule) minimising Eq. (1) of the paper, plus an optional regulariser::

    O(u) = 1/2 |y(u) - y'|^2  +  w/2 |u - u_ref|^2,      dO/du = J^T (y - y') + w (u - u_ref)

``y(u)`` and ``J = dy/du`` (3, m) m/rad come from any object with
``predict_and_jacobian(u) -> (y (3,), J (3, m))``: the learned network
(:class:`lab.learn.mlp.MLP`, analytic network Jacobian) or the FEM with sensitivity
analysis (:class:`lab.control.soft_ik.FEMForwardMap`, "Soft IK"). ``w`` (m^2/rad^2, default 0)
pulls towards ``u_ref``. A model with ensemble members may add the spread penalty
``s/2 S(u)`` (``spread_weight``; :mod:`lab.control.spread`), as least-squares rows next to
``y - y'``; every answer reports the model's predicted spread there and is flagged
``uncertain`` above ``max_spread_m``.

Trajectories, and how a redundant arm (more motors than tip coordinates) picks one of its
many answers -- continuity and posture weights, the polish, restarts from slack plateaus,
and what happens when the weights are given as ``None`` -- are :mod:`lab.control.follow`.

Solvers, all keeping every iterate in ``C``:

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
* ``"dfo"`` -- derivative-free: secant LM steps with a compass poll (:mod:`lab.control.dfo`),
  for models without a Jacobian (``has_jacobian = False``, e.g. k-NN); only ``predict``.

Stopping (LM and GD): ``converged`` when the tip residual ``|y - y'|`` <= ``tol_m`` (not with a
spread penalty, whose optimum moves off a reached target: there stationarity decides);
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
training data or :func:`grid_seeds`), else at the projection of the box centre.
"""

from __future__ import annotations

import math
import time

import numpy as np

from lab.control.command_set import CommandSet
from lab.control.dfo import dfo_solve
from lab.control.follow import follow_trajectory
from lab.control.ik_result import IKResult, TrajectoryIK, check_targets, count_work  # noqa: F401 (re-exported)
from lab.control.spread import DEFAULT_MAX_SPREAD_M, has_spread, members_of, predicted_spread_m, spread_rows
from lab.errors import InputError

METHODS = ("lm", "gd", "dfo")
#: Sufficient-decrease constant of gradient descent's Armijo test (see the module docstring).
ARMIJO = 0.5


def grid_seeds(forward, commands: CommandSet, levels: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Cold-start seeds: the allowed points of a ``levels``^m grid and their predicted tips
    (u (S, m) rad, y (S, 3) m). Needs a batched ``forward.predict`` (e.g. the network)."""
    axes = [np.linspace(lo, hi, levels) for lo, hi in zip(commands.lo, commands.hi)]
    u = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, commands.n)
    u = u[np.all(u @ commands.A.T <= commands.b + commands.tol, axis=1)]
    return u, np.asarray(forward.predict(u), dtype=float)


class IKSolver:
    """IK for one forward map and command set. ``method``: "lm", "gd" or "dfo" (module docstring).

    ``tol_m``: stop when the tip residual is below this (m); ``reach_tol_m``: residual up to
    which a target counts as reached; ``tol_stationary``: relative stationarity tolerance;
    ``reg_weight``: ``w`` of the regulariser (m^2/rad^2); ``posture_weight``, ``u_posture``
    (default the centre of the allowed set) and ``polish``: how :meth:`follow` picks among
    redundant solutions; ``None`` weights are automatic (:mod:`lab.control.follow`: 0, and on
    a redundant arm regularised restarts where a point is missed; a plain :meth:`solve` uses 0);
    ``retry_cold``: :meth:`follow` solves a point that misses its target again from other
    starts and keeps the best; ``seeds``: (u (S, m), y (S, 3)) for cold starts.
    ``spread_weight``: ``s`` of the spread penalty (dimensionless; needs ensemble
    ``members``); ``max_spread_m``: spread (m) above which an answer is ``uncertain``
    (default :data:`lab.control.spread.DEFAULT_MAX_SPREAD_M` for a model with a spread).
    ``max_iter`` defaults to 100 (lm), 20000 (gd) or 200 (dfo). ``record_history``:
    keep the tip residual of every iterate in ``IKResult.history_m`` (for plots). ``notes``:
    choices made for this solver, in words (e.g. :func:`lab.tracking.track.make_solver`'s).
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
        reg_weight: float | None = 0.0,
        posture_weight: float | None = 0.0,
        u_posture=None,
        polish: bool = True,
        retry_cold: bool = True,
        seeds=None,
        record_history: bool = False,
        spread_weight: float = 0.0,
        max_spread_m: float | None = None,
    ):
        if method not in METHODS:
            raise InputError(f"method must be one of {METHODS}, got {method!r}")
        for name, w in (
            ("reg_weight", reg_weight),
            ("posture_weight", posture_weight),
            ("spread_weight", spread_weight),
        ):
            if w is not None and (w < 0 or not np.isfinite(w)):
                raise InputError(f"{name} must be finite and >= 0, got {w}")
        if spread_weight > 0 and members_of(forward) is None:
            raise InputError("spread_weight > 0 needs a model with ensemble members (e.g. a deep ensemble)")
        if max_spread_m is not None and not (max_spread_m > 0 and np.isfinite(max_spread_m)):
            raise InputError(f"max_spread_m must be finite and > 0 (m), got {max_spread_m}")
        self.forward, self.commands, self.method = forward, commands, method
        self.tol_m, self.reach_tol_m = float(tol_m), float(reach_tol_m)
        self.tol_stationary = float(tol_stationary)
        self.max_iter = int(max_iter or {"lm": 100, "gd": 20000, "dfo": 200}[method])
        self.reg_weight_setting, self.posture_weight_setting = reg_weight, posture_weight  # None: automatic
        self.reg_weight, self.posture_weight = float(reg_weight or 0.0), float(posture_weight or 0.0)
        self.n_tip = int(getattr(forward, "n_y", 3))
        self.redundant = commands.n > self.n_tip
        self.spread_weight = float(spread_weight)
        self.notes: list[str] = []  # choices made for this solver, in words (e.g. by make_solver)
        self.has_spread = has_spread(forward)
        self.max_spread_m = (
            (DEFAULT_MAX_SPREAD_M if self.has_spread else None) if max_spread_m is None else float(max_spread_m)
        )
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
        run = {"lm": self._lm, "gd": self._gd, "dfo": lambda *a: dfo_solve(self, *a)}[self.method]
        keep, self.reg_weight = self.reg_weight, self.reg_weight if reg_weight is None else float(reg_weight)
        try:
            res = run(target, u, u_ref)
        finally:
            self.reg_weight = keep
        if self.has_spread:
            res.spread_m = predicted_spread_m(self.forward, res.u_motor)
            res.uncertain = bool(self.max_spread_m is not None and res.spread_m > self.max_spread_m)
        res.time_s = time.perf_counter() - t0
        return res

    def follow(self, targets_W, u0=None) -> TrajectoryIK:
        """IK for each of the targets (N, 3) m in order, warm-starting every point from the
        previous solution (the first from ``u0`` (m,) rad or a cold start), regularised and
        polished on a redundant arm, with restarts where a point misses:
        :func:`lab.control.follow.follow_trajectory`."""
        return follow_trajectory(self, targets_W, u0)

    # ----------------------------------------------------------------- internals
    def _evaluate(self, u, target, u_ref):
        """(y, objective, rows) at u: ``rows`` = (r, J_r), the tip residual with the spread
        penalty's rows stacked under it (its Jacobian); objective is inf where the forward map
        gives no finite answer."""
        y, J = self.forward.predict_and_jacobian(u)
        y, J = np.asarray(y, dtype=float), np.asarray(J, dtype=float)
        r, J_r = y - target, J
        if self.spread_weight > 0:
            r_s, J_s = spread_rows(self.forward, u, self.spread_weight)
            r, J_r = np.concatenate([r, r_s]), np.vstack([J, J_s])
        if not (np.isfinite(r).all() and np.isfinite(J_r).all()):
            return y, np.inf, (r, J_r)
        obj = 0.5 * float(r @ r)
        if self.reg_weight:
            du = u - u_ref
            obj += 0.5 * self.reg_weight * float(du @ du)
        return y, obj, (r, J_r)

    def _gradient(self, u, rows, u_ref):
        g = rows[1].T @ rows[0]
        return g + self.reg_weight * (u - u_ref) if self.reg_weight else g

    def _stationary(self, u, g, lipschitz, obj) -> bool:
        """Projected gradient small relative to |J_r|_F |r| (module docstring); lipschitz =
        |J|_F^2 + w, and |J_r|_F^2 = |J|_F^2 + m w <= m lipschitz bounds it from above."""
        if lipschitz <= 0:  # J = 0 and no regulariser (every cable slack): the gradient is zero
            return True
        step = u - self.commands.project(u - g / lipschitz, x0=u)
        pg = lipschitz * math.sqrt(step @ step)
        return pg <= self.tol_stationary * math.sqrt(len(u) * lipschitz * 2.0 * obj)

    def _result(self, u, y, obj, target, status, it, n_eval, history) -> IKResult:
        res = float(np.linalg.norm(y - target))
        if status != "converged" and res <= self.tol_m:
            status = "converged"
        return IKResult(u, y, res, obj, res <= self.reach_tol_m, status, it, n_eval, 0.0, history)

    def _record(self, history, y, target) -> None:
        if self.record_history:
            history.append(float(np.linalg.norm(y - target)))

    def _first(self, u, target, u_ref):
        y, obj, rows = self._evaluate(u, target, u_ref)
        if not np.isfinite(obj):
            raise InputError(f"the forward map gives no finite tip at the start command {u.tolist()} rad")
        return y, obj, rows

    def _lm(self, target, u, u_ref) -> IKResult:
        y, obj, rows = self._first(u, target, u_ref)
        w, n_eval, nu, mu, eye = self.reg_weight, 1, 2.0, None, np.eye(len(u))
        status, history = "max_iter", []
        self._record(history, y, target)
        for it in range(self.max_iter):  # noqa: B007 (it is the iteration count after the loop)
            e = y - target
            if self.spread_weight == 0 and math.sqrt(e @ e) <= self.tol_m:
                status = "converged"
                break
            g, J_r = self._gradient(u, rows, u_ref), rows[1]
            JtJ = J_r.T @ J_r + w * eye if w else J_r.T @ J_r
            lip = float((J_r * J_r).sum()) + w
            if self._stationary(u, g, lip, obj):
                status = "stationary"
                break
            if mu is None:
                mu = 1e-3 * float(np.max(np.diag(JtJ)))
            H = JtJ + mu * eye
            try:
                d = -np.linalg.solve(H, g)
                if not self.commands.contains(u + d, 0.0):
                    d = self.commands.solve_qp(H, g - H @ u, x0=u) - u
            except np.linalg.LinAlgError:
                # a redundant arm's J^T J has rank 3: after many good steps mu can fall below
                # rounding against it and H is singular. Damp more, as after a rejected step.
                mu = max(mu * nu, 1e-12 * lip)
                nu *= 2.0
                continue
            predicted = -(g @ d + 0.5 * d @ JtJ @ d)
            if predicted <= 1e-30 or abs(d).max() <= 1e-15 * self.commands.scale:
                status = "stalled"
                break
            u_new = u + d
            y_new, obj_new, rows_new = self._evaluate(u_new, target, u_ref)
            n_eval += 1
            rho = (obj - obj_new) / predicted
            if rho > 0:  # accept: Nielsen's update
                u, y, obj, rows = u_new, y_new, obj_new, rows_new
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
        y, obj, rows = self._first(u, target, u_ref)
        n_eval, alpha, status, history = 1, None, "max_iter", []
        self._record(history, y, target)
        for it in range(self.max_iter):  # noqa: B007 (it is the iteration count after the loop)
            if self.spread_weight == 0 and np.linalg.norm(y - target) <= self.tol_m:
                status = "converged"
                break
            g = self._gradient(u, rows, u_ref)
            lip = float(np.sum(rows[1] ** 2)) + self.reg_weight
            if self._stationary(u, g, lip, obj):
                status = "stationary"
                break
            a = 1.0 / lip if alpha is None else 2.0 * alpha
            for _ in range(60):  # Armijo along the projection arc
                u_new = self.commands.project(u - a * g, x0=u)
                y_new, obj_new, rows_new = self._evaluate(u_new, target, u_ref)
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
            u, y, obj, rows, alpha = u_new, y_new, obj_new, rows_new, a
            self._record(history, y, target)
        else:
            it = self.max_iter
        return self._result(u, y, obj, target, status, it, n_eval, history)
