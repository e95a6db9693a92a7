"""The prior of a calibration: what is fitted by default, and how far each parameter may stray.

:func:`lab.transfer.calibrate` pulls theta towards the nominal description with independent
Gaussian priors, one standard deviation per block of theta (:data:`DEFAULT_PRIOR_STD`);
:func:`default_groups` says which groups a robot fits when none are asked for.
"""

from __future__ import annotations

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError
from lab.fem.solve.parameter_layout import DEFAULT_GROUPS, ParameterLayout

__all__ = ["DEFAULT_PRIOR_STD", "default_groups", "prior_std"]

#: Prior standard deviations of each block of theta (the nominal is the prior mean):
#: log softness 0.4 (E x/ 1.5), gradient 0.4 per component, eyelet shift 2 mm per axis,
#: slack 3 mm -- about the half-widths of the as-built family's ranges -- and the density
#: factor 0.3 (a cast foam's density is known to about a third).
DEFAULT_PRIOR_STD = {"log_softness": 0.4, "gradient": 0.4, "via_shift_m": 2e-3, "slack_m": 3e-3, "density": 0.3}


def prior_std(layout: ParameterLayout, std=None) -> np.ndarray:
    """Prior standard deviations (p,): ``std`` as an array (p,), or a dict overriding blocks
    of :data:`DEFAULT_PRIOR_STD` (keys as there).

    Parameters
    ----------
    layout : ParameterLayout
        The parameter layout theta follows.
    std : array_like or dict, optional
        Standard deviations (p,) in theta's units, or a dict overriding blocks of
        :data:`DEFAULT_PRIOR_STD`; default: those.

    Returns
    -------
    numpy.ndarray
        The prior standard deviation of each parameter, shape (p,).
    """
    if std is not None and not isinstance(std, dict):
        s = np.asarray(std, float)
        if s.shape != (layout.size,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise InputError(f"prior std must be {layout.size} positive numbers, got {s.tolist()}")
        return s
    d = {**DEFAULT_PRIOR_STD, **(std or {})}
    unknown = set(d) - set(DEFAULT_PRIOR_STD)
    if unknown or not all(np.isfinite(v) and v > 0 for v in d.values()):
        raise InputError(f"prior std: positive values for {sorted(DEFAULT_PRIOR_STD)}, got {d}")
    s = np.empty(layout.size)
    for group, key in (("softness", "log_softness"), ("gradient", "gradient"), ("eyelets", "via_shift_m"),
                       ("slack", "slack_m"), ("density", "density")):  # fmt: skip
        s[layout.block(group)] = d[key]
    return s


def default_groups(robot: RobotDescription) -> tuple[str, ...]:
    """The groups fitted by default: softness, gradient, eyelets and, with an
    angle-controlled cable, slack.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.

    Returns
    -------
    tuple of str
        Group names (:data:`lab.fem.solve.parameter_layout.GROUPS`).
    """
    if any(c.control == "angle" for c in robot.cables):
        return DEFAULT_GROUPS
    if not robot.cables:  # chambers only: no eyelets, no slack
        return tuple(g for g in DEFAULT_GROUPS if g not in ("slack", "eyelets"))
    return tuple(g for g in DEFAULT_GROUPS if g != "slack")
