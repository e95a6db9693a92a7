"""The IK's settings: one frozen :class:`IKConfig` instead of a bag of keyword arguments.

Every setting of :class:`lab.control.ik.IKSolver` -- the method, its tolerances, the
regulariser and posture weights, the spread penalty, the follow options -- is a field here,
validated when the config is made (:class:`lab.errors.InputError` naming the field, or its
flag). The fields ``python -m lab track`` sets carry their flag, so the command builds its
IK flags from this class (:func:`lab.cli.flags.add_spec_flags`). What the settings mean is
in docs/design/ik.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real

from lab.errors import InputError
from lab.specs import Spec, non_negative, option, positive, positive_int

__all__ = ["METHODS", "DEFAULT_MAX_ITER", "IKConfig"]

METHODS = ("lm", "gd", "dfo")
#: Iteration limit of each method when ``max_iter`` is not set.
DEFAULT_MAX_ITER = {"lm": 100, "gd": 20000, "dfo": 200}

_FLOATS = ("reg_weight", "posture_weight", "spread_weight", "max_spread_m", "tol_m", "reach_tol_m", "tol_stationary")
_INTS = ("max_iter", "seed_levels")
_BOOLS = ("polish", "retry_cold", "record_history", "smooth_path")


def _comma_separated(text: str) -> tuple[str, ...]:
    """The names of a comma-separated text (checked by :func:`_marker_names`)."""
    return tuple(text.split(","))


def _marker_names(value) -> tuple[str, ...]:
    """Marker names from a comma-separated text or a sequence of names."""
    names = value.split(",") if isinstance(value, str) else value
    try:
        names = tuple(str(n).strip() for n in names)
    except TypeError:
        names = ()
    if not names or not all(names) or len(set(names)) != len(names):
        raise InputError(f"markers must be distinct marker names (e.g. tip or tip,mid), got {value!r}")
    return names


@dataclass(frozen=True)
class IKConfig(Spec):
    """Settings of the IK (docs/design/ik.md). The defaults are a plain solver: bounded
    Levenberg-Marquardt, no regulariser. :meth:`automatic` gives those of ``python -m lab
    track`` and :meth:`lab.control.ik.IKSolver.for_model`: the method picked for the model
    and automatic weights. ``None`` fields are filled in by the solver
    (``IKSolver.config`` holds the filled-in copy).

    Attributes
    ----------
    method : str or None
        "lm", "gd" or "dfo" (:data:`METHODS`); None: picked for the model.
    reg_weight, posture_weight : float or None
        Regularisers towards the previous command and towards the posture (m^2/rad^2);
        None: automatic.
    spread_weight : float
        Weight (dimensionless, m^2 per m^2 of tip error) on the ensemble's spread.
    max_spread_m : float or None
        Spread (m) above which an answer is flagged uncertain.
    tol_m, reach_tol_m : float
        Tip residual (m) to stop at, and up to which a target counts as reached.
    tol_stationary : float
        Relative stationarity tolerance (dimensionless).
    max_iter : int or None
        Iteration limit; None: :data:`DEFAULT_MAX_ITER` of the method.
    u_posture : tuple of float or None
        Posture (m,) rad of the posture weight; None: the centre of the allowed set.
    polish, retry_cold, record_history : bool
        Solve a regularised answer again unregularised; solve a missed point again from
        other starts; keep every iterate's tip residual.
    smooth_path : bool
        With automatic weights on a redundant arm: regularise every point towards the
        previous command and (a hundredth as much) the posture, then polish, so that
        neighbouring targets' commands stay on one branch of solutions instead of
        drifting to a bound and jumping across the box at a restart
        (:func:`lab.control.follow.follow_weights`).
    seed_levels : int or None
        Cold-start grid levels of ``for_model`` (None: 7, or 4 beyond 3 motors).
    markers : tuple of str
        The observed points the IK drives, in the target's order: ``("tip",)`` (a (3,)
        target) by default; any of the robot's markers (3 target coordinates each).
    """

    method: str | None = option(
        "lm",
        choices=METHODS,
        help="bounded Levenberg-Marquardt, projected gradient descent, or derivative-free IK (secant LM "
        "steps and a compass poll; default: lm, or dfo for a model without a Jacobian)",
    )
    reg_weight: float | None = option(
        0.0,
        type=float,
        check=non_negative,
        help="regulariser towards the previous command on every point, m^2/rad^2 (default auto: none; "
        "on a redundant arm a missed target is solved again from the posture, regularised with a "
        "thousandth of the model's mean squared Jacobian column, and polished; 0 is off)",
    )
    posture_weight: float | None = option(
        0.0,
        type=float,
        check=non_negative,
        help="regulariser towards the centre of the allowed commands (keeps a redundant "
        "arm's cables taut) on every point, m^2/rad^2 (default auto, as --reg-weight); regularised answers "
        "are polished",
    )
    spread_weight: float = option(
        0.0,
        type=float,
        check=non_negative,
        help="penalise the model ensemble's spread at the command (dimensionless weight on its "
        "variance, m^2 per m^2 of tip error; needs an ensemble model; 0 is off)",
    )
    max_spread_m: float | None = option(
        None,
        cli=False,
        check=positive,
        unit="m",
        help="spread (m) above which an answer is flagged uncertain (default 1 mm for a model with a spread)",
    )
    tol_m: float = option(1e-8, cli=False, check=non_negative, unit="m", help="stop at this tip residual, m")
    reach_tol_m: float = option(
        1e-5, cli=False, check=non_negative, unit="m", help="residual up to which a target is reached, m"
    )
    tol_stationary: float = option(1e-6, cli=False, check=non_negative, help="relative stationarity tolerance")
    max_iter: int | None = option(
        None, cli=False, check=positive_int, help="iteration limit (default 100 lm, 20000 gd, 200 dfo)"
    )
    u_posture: tuple[float, ...] | None = option(
        None, cli=False, help="posture (m,) rad of the posture weight (default the centre of the allowed set)"
    )
    polish: bool = option(True, cli=False, help="solve a regularised answer again unregularised")
    retry_cold: bool = option(True, cli=False, help="solve a missed point again from other starts")
    record_history: bool = option(False, cli=False, help="keep every iterate's tip residual")
    smooth_path: bool = option(
        False,
        cli=False,
        help="with automatic weights on a redundant arm, regularise every point towards the previous command "
        "and the posture, then polish: neighbouring targets' commands do not jump across the box",
    )
    seed_levels: int | None = option(
        None, cli=False, check=positive_int, help="cold-start grid levels of for_model (default 7, 4 beyond 3 motors)"
    )

    markers: tuple[str, ...] = option(
        ("tip",),
        type=_comma_separated,
        help="comma-separated markers whose positions the IK drives (tip, or the robot's [[markers]] names; "
        "each follows the trajectory shifted by its rest offset from the tip)",
    )

    def __post_init__(self):
        object.__setattr__(self, "markers", _marker_names(self.markers))
        for name in _FLOATS + _INTS + _BOOLS:
            value = getattr(self, name)
            if value is None and name != "spread_weight":
                continue
            if name in _BOOLS:
                value = bool(value)
            elif name in _INTS and isinstance(value, Integral) and not isinstance(value, bool):
                value = int(value)
            elif name in _FLOATS and isinstance(value, Real) and not isinstance(value, bool):
                value = float(value)
            else:
                raise InputError(f"{name} must be a {'number' if name in _FLOATS else 'whole number'}, got {value!r}")
            object.__setattr__(self, name, value)
        if self.u_posture is not None:
            try:
                posture = tuple(float(v) for v in self.u_posture)
            except (TypeError, ValueError):
                posture = ()
            if not posture or not all(math.isfinite(v) for v in posture):
                raise InputError(f"u_posture must be finite angles in rad, got {self.u_posture!r}")
            object.__setattr__(self, "u_posture", posture)
        super().__post_init__()

    @classmethod
    def automatic(cls, **changes) -> IKConfig:
        """The defaults of ``python -m lab track`` and ``IKSolver.for_model``.

        Parameters
        ----------
        **changes
            Fields to set otherwise.

        Returns
        -------
        IKConfig
            The method picked for the model (lm, or dfo without a Jacobian) and automatic
            weights (docs/design/ik.md), with ``changes``.
        """
        return cls(**{"method": None, "reg_weight": None, "posture_weight": None, **changes})
