"""Planning the data-efficiency study, and reading its rows.

The sampling strategies (:data:`STRATEGIES`) and forward models (:data:`MODELS`) a study may
use, checked against this install (:func:`check_strategies`, :func:`check_model`); the rows
it measures in order (:func:`plan_rows`, the grids nearest each N from
:func:`grid_levels_for`); and, once measured, how sparse each strategy can go
(:func:`smallest_n`) and what that saves in capture time against the paper's 7^3 grid
(:func:`hours_saved`, :data:`PAPER_GRID_N` = 308 samples). One row is measured by
:func:`lab.studies.data_curve.data_curve_row`.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError

__all__ = [
    "STRATEGIES",
    "PAPER_GRID_N",
    "MODELS",
    "check_strategies",
    "check_model",
    "grid_levels_for",
    "plan_rows",
    "smallest_n",
    "hours_saved",
]

#: Sampling strategies: a grid of L levels per motor (safe points), scrambled Sobol, Latin
#: hypercube, greedy maximin, independent uniform draws, and active sampling (batches where a
#: deep ensemble disagrees most; :func:`lab.learn.active.active_sampling`).
STRATEGIES = ("grid", "sobol", "lhs", "maximin", "random", "active")
#: The paper's training set: the safe points of the 7^3 grid of the three-cable arm.
PAPER_GRID_N = 308
#: Forward models a row can fit (:func:`fit_forward_model`; not the direct inverse, which
#: predicts no tip).
MODELS = ("mlp", "ensemble", "gpr", "knn", "sklearn-mlp")


def check_strategies(strategies) -> list[str]:
    """The strategies, checked: known (:data:`STRATEGIES`) and available in this install
    (``lhs`` needs it in :data:`lab.data.designs.DESIGNS`, ``active`` needs
    :mod:`lab.learn.active`); InputError naming the problem otherwise."""
    from lab.data.designs import DESIGNS

    out = list(dict.fromkeys(strategies))
    unknown = [s for s in out if s not in STRATEGIES]
    if unknown or not out:
        raise InputError(f"unknown sampling strategy {unknown or '(none)'}: expected some of {', '.join(STRATEGIES)}")
    if "lhs" in out and "lhs" not in DESIGNS:
        raise InputError("strategy 'lhs' is not available: lab.data.designs has no Latin hypercube design")
    if "active" in out:
        try:
            from lab.learn.active import active_sampling  # noqa: F401
            from lab.learn.ensemble import train_ensemble  # noqa: F401
        except ImportError as err:
            raise InputError(f"strategy 'active' is not available in this install ({err})") from None
    return out


def check_model(name: str) -> str:
    """``name`` if it is one of :data:`MODELS` and this install can fit it, else InputError."""
    if name not in MODELS:
        raise InputError(f"unknown model {name!r}: expected one of {', '.join(MODELS)}")
    if name != "mlp":
        try:
            from lab.learn.models import fit_model  # noqa: F401
        except ImportError:
            raise InputError(f"model {name!r} is not available (lab.learn.models is missing); use mlp") from None
    return name


def grid_levels_for(robot, ns, levels=None) -> dict[int, int]:
    """``{levels: safe count}`` of the grids to measure: the given ``levels``, else for each
    N of ``ns`` the number of levels per motor whose safe count is nearest N (ties: fewer
    levels). The safe count is the N a grid row records."""
    from lab.data.designs import grid_commands

    if levels:
        bad = [lv for lv in levels if int(lv) < 2]
        if bad:
            raise InputError(f"a grid needs at least 2 levels per motor, got {bad}")
        return {int(lv): len(grid_commands(robot, int(lv))) for lv in sorted(set(levels))}
    counts, lv = {}, 2
    while True:  # counts grow with the levels; stop once past the largest N
        counts[lv] = len(grid_commands(robot, lv))
        if counts[lv] >= max(ns) or lv > 64:
            break
        lv += 1
    picked = {min(counts, key=lambda k: (abs(counts[k] - n), k)) for n in ns}
    return {k: counts[k] for k in sorted(picked)}


def plan_rows(robot, strategies, ns, grid_levels=None) -> list[tuple[str, int, int | None]]:
    """The rows of a study in the order they are measured: strategy by strategy, N increasing.

    Parameters
    ----------
    robot : RobotDescription
        The robot (its grids' safe counts).
    strategies, ns : sequence of str, sequence of int
        Sampling strategies (:data:`STRATEGIES`) and sample counts N (each >= 1).
    grid_levels : sequence of int, optional
        Grid levels per motor (None: those nearest each N, :func:`grid_levels_for`).

    Returns
    -------
    list of tuple
        ``(strategy, n, levels)``, ``levels`` None but for grids.
    """
    ns = sorted({int(n) for n in ns})
    if not ns or ns[0] < 1:
        raise InputError(f"every N must be >= 1, got {ns}")
    rows = []
    for s in strategies:
        if s == "grid":
            rows += [("grid", n, lv) for lv, n in grid_levels_for(robot, ns, grid_levels).items()]
        else:
            rows += [(s, n, None) for n in ns]
    return rows


def smallest_n(rows, metric: str, threshold: float) -> dict:
    """Per strategy, the smallest N whose ``metric`` (e.g. ``model_error_m`` <= 0.5e-3, or
    ``tracking_mean_m`` <= 1.5e-3) is at most ``threshold``, with that value: ``(n, value)``,
    or None if no N reaches it. Rows of several robots or seeds are averaged per N."""
    out = {}
    for s in dict.fromkeys(r["strategy"] for r in rows):
        per_n: dict[int, list] = {}
        for r in rows:
            if r["strategy"] == s and np.isfinite(float(r[metric])):
                per_n.setdefault(int(r["n"]), []).append(float(r[metric]))
        hit = [(n, float(np.mean(v))) for n, v in sorted(per_n.items()) if np.mean(v) <= threshold]
        out[s] = hit[0] if hit else None
    return out


def hours_saved(n: int, samples_per_hour: float, reference_n: int = PAPER_GRID_N) -> float:
    """Capture hours saved by capturing ``n`` samples instead of ``reference_n``.

    Parameters
    ----------
    n, reference_n : int
        Samples captured; the reference count (default: the paper's 7^3 grid).
    samples_per_hour : float
        Capture rate.

    Returns
    -------
    float
        Hours saved (h; negative: it costs more).
    """
    return (reference_n - n) / samples_per_hour
