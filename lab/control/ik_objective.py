"""The objective every IK method minimises, and the stopping rules they share.

``O(u) = 1/2 |r(u)|^2 + w/2 |u - u_ref|^2`` with ``r = y(u) - y'`` (3,) m, plus the spread
penalty's rows (:mod:`lab.control.spread`) under it; :class:`Objective` evaluates it and its
gradient for one target. :func:`is_stationary` is the projected-gradient test,
:func:`conclude` turns where a method stopped into an :class:`IKResult`, :func:`record`
keeps the residual history (docs/design/ik.md: stopping).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lab.control.command_set import CommandSet
from lab.control.ik_config import IKConfig
from lab.control.ik_result import IKResult
from lab.control.spread import spread_rows
from lab.errors import InputError

__all__ = ["Objective", "is_stationary", "conclude", "record"]


@dataclass(frozen=True, eq=False)
class Objective:
    """``O`` for one ``target`` (3,) m through ``forward`` (``predict_and_jacobian``), pulled
    to ``u_ref`` (m,) rad with ``reg_weight`` ``w`` (m^2/rad^2), with the spread penalty's
    ``spread_weight`` (dimensionless; 0: none)."""

    forward: object
    target: np.ndarray
    u_ref: np.ndarray
    reg_weight: float
    spread_weight: float

    def evaluate(self, u):
        """(y (3,) m, O, rows) at ``u`` (m,) rad: ``rows`` = (r, J_r), the tip residual with the
        spread rows stacked under it, and its Jacobian; ``O`` is inf where the forward map
        gives no finite answer."""
        y, J = self.forward.predict_and_jacobian(u)
        y, J = np.asarray(y, dtype=float), np.asarray(J, dtype=float)
        r, J_r = y - self.target, J
        if self.spread_weight > 0:
            r_s, J_s = spread_rows(self.forward, u, self.spread_weight)
            r, J_r = np.concatenate([r, r_s]), np.vstack([J, J_s])
        if not (np.isfinite(r).all() and np.isfinite(J_r).all()):
            return y, np.inf, (r, J_r)
        obj = 0.5 * float(r @ r)
        if self.reg_weight:
            du = u - self.u_ref
            obj += 0.5 * self.reg_weight * float(du @ du)
        return y, obj, (r, J_r)

    def first(self, u):
        """:meth:`evaluate` at the start ``u``; InputError where the forward map gives no finite tip."""
        y, obj, rows = self.evaluate(u)
        if not np.isfinite(obj):
            raise InputError(f"the forward map gives no finite tip at the start command {u.tolist()} rad")
        return y, obj, rows

    def gradient(self, u, rows) -> np.ndarray:
        """dO/du (m,) m^2/rad at ``u`` from its ``rows``."""
        g = rows[1].T @ rows[0]
        return g + self.reg_weight * (u - self.u_ref) if self.reg_weight else g


def is_stationary(commands: CommandSet, tol_stationary: float, u, g, lipschitz: float, obj: float) -> bool:
    """Projected gradient ``pg = L (u - P(u - g/L))`` small relative to ``|J_r|_F |r|``:
    ``|pg| <= tol_stationary sqrt(m L 2 O)`` with ``L = lipschitz = |J|_F^2 + w``, as
    ``|J_r|_F^2 = |J|_F^2 + m w <= m L`` bounds it from above."""
    if lipschitz <= 0:  # J = 0 and no regulariser (every cable slack): the gradient is zero
        return True
    step = u - commands.project(u - g / lipschitz, x0=u)
    pg = lipschitz * math.sqrt(step @ step)
    return pg <= tol_stationary * math.sqrt(len(u) * lipschitz * 2.0 * obj)


def conclude(config: IKConfig, u, y, obj, target, status, iterations, evaluations, history) -> IKResult:
    """The result of a method that stopped at ``u`` (m,) rad with tip ``y`` (3,) m: its
    residual, reached (``config.reach_tol_m``) or not, and ``converged`` whenever the
    residual is within ``config.tol_m`` (``time_s`` is filled in by the solver)."""
    res = float(np.linalg.norm(y - target))
    if status != "converged" and res <= config.tol_m:
        status = "converged"
    return IKResult(u, y, res, obj, res <= config.reach_tol_m, status, iterations, evaluations, 0.0, history)


def record(config: IKConfig, history: list, y, target) -> None:
    """Append the tip residual |y - target| m to ``history`` if ``config.record_history``."""
    if config.record_history:
        history.append(float(np.linalg.norm(y - target)))
