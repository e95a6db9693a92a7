"""Inverse kinematics through a differentiable forward map (Sections II-A, II-C, II-D).

Given a target tip ``y'`` (3,) m, :class:`IKSolver` finds motor angles ``u`` (m,) rad in the
allowed set (:class:`lab.control.command_set.CommandSet`) minimising Eq. (1) of the paper,
``1/2 |y(u) - y'|^2``, plus an optional regulariser and ensemble-spread penalty, through any
forward map with ``predict_and_jacobian(u) -> (y (3,), J (3, m))``: the learned network or
the FEM (:class:`lab.control.soft_ik.FEMForwardMap`, Soft IK). Its settings are one
:class:`lab.control.ik_config.IKConfig`; the methods are :mod:`lab.control.ik_descent`
(LM, GD) and :mod:`lab.control.dfo` (no Jacobian); trajectories are
:mod:`lab.control.follow`. :meth:`IKSolver.for_model` builds the solver a command uses for a
model or the FEM. The objective, methods and stopping rules are docs/design/ik.md.
"""

from __future__ import annotations

import time

import numpy as np

from lab.control.command_set import CommandSet
from lab.control.dfo import dfo_solve
from lab.control.follow import follow_trajectory
from lab.control.ik_config import DEFAULT_MAX_ITER, METHODS, IKConfig
from lab.control.ik_descent import ARMIJO, gd_solve, lm_solve
from lab.control.ik_result import IKResult, TrajectoryIK, check_targets
from lab.control.markers import select_markers
from lab.control.soft_ik import FEMForwardMap
from lab.control.spread import DEFAULT_MAX_SPREAD_M, has_spread, members_of, predicted_spread_m
from lab.errors import InputError

__all__ = [
    "IKSolver",
    "IKConfig",
    "IKResult",
    "TrajectoryIK",
    "METHODS",
    "ARMIJO",
    "check_targets",
    "grid_seeds",
    "check_forward",
    "command_set",
]

_METHOD_RUN = {"lm": lm_solve, "gd": gd_solve, "dfo": dfo_solve}


def grid_seeds(forward, commands: CommandSet, levels: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Cold-start seeds: the allowed points of a grid of ``levels`` per motor, and their predicted tips.

    Parameters
    ----------
    forward : object
        A forward map with a batched ``predict(U (S, m) rad) -> (S, 3) m`` (e.g. the network).
    commands : CommandSet
        The allowed commands; grid points outside the linear limits are dropped.
    levels : int
        Grid levels per motor.

    Returns
    -------
    u : numpy.ndarray
        The seeds (S, m), rad.
    y : numpy.ndarray
        Their predicted tips (S, 3), m, frame W.
    """
    axes = [np.linspace(lo, hi, levels) for lo, hi in zip(commands.lo, commands.hi)]
    u = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, commands.n)
    u = u[np.all(u @ commands.A.T <= commands.b + commands.tol, axis=1)]
    return u, np.asarray(forward.predict(u), dtype=float)


def check_forward(model) -> None:
    """InputError unless ``model`` is a forward map.

    A direct inverse model ``u = g(y)`` (a ``command`` method) has none to solve the IK through.

    Parameters
    ----------
    model : object
        The model to check.
    """
    if callable(getattr(model, "command", None)):
        raise InputError(
            "this is a direct inverse model u = g(y): it has no forward map to solve the IK through; "
            "give a forward model (mlp, ensemble, gpr, knn, sklearn-mlp)"
        )


def command_set(robot=None, bounds=None) -> CommandSet:
    """The allowed commands of a robot, of a box, or of both (the robot's set cut to the box).

    Parameters
    ----------
    robot : ~lab.description.RobotDescription, optional
        Gives ``[0, u_max]^m`` and the safety limits.
    bounds : tuple of array_like, optional
        The box ``(lo (m,), hi (m,))``, rad: two finite vectors with lo < hi (else InputError).

    Returns
    -------
    CommandSet
        The allowed commands.
    """
    if bounds is None:
        return CommandSet.from_robot(robot)
    try:
        lo, hi = (np.asarray(b, dtype=float) for b in bounds)
    except (TypeError, ValueError):
        raise InputError(f"command bounds must be (lo (m,), hi (m,)) in rad, got {bounds!r}") from None
    if lo.ndim != 1 or lo.shape != hi.shape or not len(lo) or not np.all(np.isfinite(lo) & np.isfinite(hi)):
        raise InputError(f"command bounds must be two finite vectors of one length, got {lo!r}, {hi!r}")
    if np.any(lo >= hi):
        j = int(np.argmax(lo >= hi))
        raise InputError(
            f"motor {j} has no range to solve over: the bounds give [{lo[j]:g}, {hi[j]:g}] "
            "(a motor the training data never moved)"
        )
    if robot is None:
        return CommandSet(lo, hi)
    full = CommandSet.from_robot(robot)
    if len(lo) != full.n:
        raise InputError(f"the command bounds are for {len(lo)} motors, but robot {robot.name} has {full.n}")
    return CommandSet(np.maximum(full.lo, lo), np.minimum(full.hi, hi), full.A, full.b)


class IKSolver:
    """IK for one forward map and set of allowed commands. A solver does not change once made.

    Attributes: ``forward``, ``commands``, ``seeds``, ``notes`` (tuple), ``config`` (the
    settings with ``method``, ``max_iter``, ``max_spread_m`` and ``u_posture`` filled in),
    ``u_posture`` and ``centre`` (m,) rad arrays, ``n_tip``, ``redundant`` (more motors than
    tip coordinates), ``has_spread``.

    Parameters
    ----------
    forward : object
        The forward map: ``predict`` (batched, (P, m) rad -> (P, 3) m) and, unless
        ``has_jacobian = False``, ``predict_and_jacobian(u) -> ((3,) m, (3, m) m/rad)``.
    commands : CommandSet
        The allowed commands.
    config : IKConfig
        The solver's settings.
    seeds : tuple of array_like, optional
        ``(u (S, m) rad, y (S, 3) m)`` for cold starts (the start is the seed whose tip is
        nearest the target); without seeds the centre of the allowed set.
    notes : iterable of str
        Choices made for this solver, in words (e.g. :meth:`for_model`'s).
    """

    def __init__(self, forward, commands: CommandSet, config: IKConfig = IKConfig(), *, seeds=None, notes=()):
        if not isinstance(config, IKConfig):
            raise InputError(f"config must be an IKConfig (e.g. IKConfig(method='gd')), got {config!r}")
        if config.spread_weight > 0 and members_of(forward) is None:
            raise InputError("spread_weight > 0 needs a model with ensemble members (e.g. a deep ensemble)")
        forward = select_markers(forward, config.markers)
        self.forward, self.commands = forward, commands
        self.n_tip = int(getattr(forward, "n_y", 3))
        self.redundant = commands.n > self.n_tip
        self.has_spread = has_spread(forward)
        self.notes = tuple(notes)
        self.seeds = None
        if seeds is not None:
            u_s, y_s = (np.asarray(a, dtype=float) for a in seeds)
            if u_s.ndim != 2 or u_s.shape[1] != commands.n or y_s.shape != (len(u_s), self.n_tip):
                raise InputError(
                    f"seeds must be (u (S, {commands.n}), y (S, {self.n_tip})), got {u_s.shape}, {y_s.shape}"
                )
            self.seeds = (u_s, y_s)
        self.centre = commands.project(0.5 * (commands.lo + commands.hi))
        method = config.method or ("lm" if getattr(forward, "has_jacobian", True) else "dfo")
        posture = self.centre if config.u_posture is None else np.asarray(config.u_posture, dtype=float)
        if posture.shape != (commands.n,) or not commands.contains(posture):
            raise InputError(f"u_posture must be an allowed command of {commands.n} angles, got {config.u_posture!r}")
        self.config = config.replace(
            method=method,
            max_iter=config.max_iter or DEFAULT_MAX_ITER[method],
            max_spread_m=config.max_spread_m
            if config.max_spread_m is not None
            else (DEFAULT_MAX_SPREAD_M if self.has_spread else None),
            u_posture=tuple(float(v) for v in posture),
        )
        self.u_posture = np.asarray(self.config.u_posture, dtype=float)

    @classmethod
    def for_model(cls, model, robot=None, config: IKConfig | None = None, *, fem=None, bounds=None) -> IKSolver:
        """The IK solver through a model, or Soft IK through the FEM.

        Cold starts from a grid of ``config.seed_levels`` levels per motor (default 7 up to
        three motors and 4 beyond); Soft IK starts at the centre and has no spread flag.
        A ``method`` of None picks "lm", or the derivative-free "dfo" for a model with
        ``has_jacobian = False`` (``notes`` say so). InputError for "lm"/"gd" on such a model,
        a direct inverse model, a model of another shape than the commands and a 3-D tip
        (naming both), or bad bounds.

        Parameters
        ----------
        model : object or None
            The forward model (``predict_and_jacobian`` and a batched ``predict``); None for
            Soft IK through ``fem``.
        robot : ~lab.description.RobotDescription, optional
            Its allowed commands (``[0, u_max]`` and its safety limits).
        config : IKConfig, optional
            The settings; default :meth:`IKConfig.automatic`.
        fem : ArmFEM, optional
            The FEM of ``robot``, for Soft IK.
        bounds : tuple of array_like, optional
            Without a robot description, the box ``(lo (m,), hi (m,))`` rad, the range of the
            model's training data (``lab.learn.data_bounds(model)``: this stage does not read
            model files); with both, their intersection.

        Returns
        -------
        IKSolver
            The solver, its choices in ``notes``.
        """
        config = IKConfig.automatic() if config is None else config
        if robot is None and (model is None or bounds is None):
            raise InputError(
                "without a robot description the IK needs a model and the bounds of its training data "
                "(lab.learn.data_bounds(model))"
            )
        if model is None:
            if fem is None:
                raise InputError("need a model or an FEM (Soft IK) to solve the IK")
            commands = CommandSet.from_robot(robot)
            forward = FEMForwardMap(fem, markers=config.markers)
            return cls(forward, commands, config.replace(method=config.method or "lm", max_spread_m=None))
        check_forward(model)
        commands = command_set(robot, bounds)
        model = select_markers(model, config.markers)
        n_u, n_y = getattr(model, "n_u", commands.n), getattr(model, "n_y", 3)
        if n_u != commands.n:
            raise InputError(
                f"the model maps {n_u} inputs to {n_y} outputs, but "
                + (f"robot {robot.name} has {robot.n_inputs} cables" if robot is not None else "")
                + (" and " if robot is not None and bounds is not None else "")
                + (f"the command bounds are for {len(bounds[0])} motors" if bounds is not None else "")
            )
        notes, method = [], config.method or "lm"
        if not getattr(model, "has_jacobian", True):
            if config.method in ("lm", "gd"):
                raise InputError(
                    f"method {config.method!r} needs the model's Jacobian, and this model has none: "
                    "use the derivative-free 'dfo' (or leave the method out)"
                )
            if config.method is None:
                notes.append(
                    "the model has no Jacobian: derivative-free IK (secant Levenberg-Marquardt with a compass poll)"
                )
            method = "dfo"
        levels = config.seed_levels or (7 if commands.n <= 3 else 4)
        seeds = grid_seeds(model, commands, levels)
        return cls(model, commands, config.replace(method=method), seeds=seeds, notes=notes)

    def initial_guess(self, target_W) -> np.ndarray:
        """Cold start for one target: the nearest seed (projected into C) or the centre.

        Parameters
        ----------
        target_W : array_like
            The tip target (3,), m, frame W.

        Returns
        -------
        numpy.ndarray
            The start command (m,), rad.
        """
        if self.seeds is None:
            return self.centre.copy()
        u_s, y_s = self.seeds
        return self.commands.project(u_s[int(np.argmin(np.sum((y_s - target_W) ** 2, axis=1)))])

    def solve(self, target_W, u0=None, u_ref=None, reg_weight: float | None = None) -> IKResult:
        """Solve for one target. Changes nothing in the solver.

        Parameters
        ----------
        target_W : array_like
            The tip target (3,), m, frame W.
        u0 : array_like, optional
            The start (m,), rad; default :meth:`initial_guess`.
        u_ref : array_like, optional
            The command (m,), rad, to regularise towards; default ``u0``.
        reg_weight : float, optional
            Weight of the regularisation (m^2/rad^2); default the config's (an automatic
            ``None`` meaning 0 here).

        Returns
        -------
        IKResult
            The command, the predicted tip, the residual and how the solve went.
        """
        target = check_targets(target_W, self.n_tip)
        if target.ndim != 1:
            raise InputError(f"solve takes one target ({self.n_tip},), got {target.shape}; use follow() for many")
        t0 = time.perf_counter()
        u = self.initial_guess(target) if u0 is None else np.asarray(u0, dtype=float)
        if u.shape != (self.commands.n,) or not np.all(np.isfinite(u)):
            raise InputError(f"u0 must be {self.commands.n} finite angles in rad, got {u0!r}")
        u = self.commands.project(u)
        u_ref = u.copy() if u_ref is None else np.asarray(u_ref, dtype=float)
        if u_ref.shape != u.shape or not np.all(np.isfinite(u_ref)):
            raise InputError(f"u_ref must be {self.commands.n} finite angles in rad, got {u_ref!r}")
        w = float(self.config.reg_weight or 0.0) if reg_weight is None else float(reg_weight)
        run = _METHOD_RUN[self.config.method]
        res = run(self.forward, self.commands, self.config, target, u, u_ref, w)
        if self.has_spread:
            res.spread_m = predicted_spread_m(self.forward, res.u_motor)
            res.uncertain = bool(self.config.max_spread_m is not None and res.spread_m > self.config.max_spread_m)
        res.time_s = time.perf_counter() - t0
        return res

    def follow(self, targets_W, u0=None) -> TrajectoryIK:
        """IK for each target in order: :func:`lab.control.follow.follow_trajectory`.

        Every point is warm-started from the previous solution, regularised and polished on
        a redundant arm, with restarts where a point misses.

        Parameters
        ----------
        targets_W : array_like
            Tip targets (N, 3), m, frame W.
        u0 : array_like, optional
            The first point's start (m,), rad; default a cold start.

        Returns
        -------
        TrajectoryIK
            Per point: commands, predicted tips, residuals, reachability, and ``info``.
        """
        return follow_trajectory(self, targets_W, u0)
