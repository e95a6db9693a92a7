"""Figures of the data-efficiency chapter (08): error against N, and an ensemble's calibration.

:func:`plot_error_vs_n` draws, per sampling strategy, a metric of
:mod:`lab.studies.data_curve` against the number of samples N on log-log axes (the mean
over the rows of each N: several seeds or robots; a bar spans their range), one
panel per (data set, metric). :func:`plot_calibration` draws the reliability curve of a
predicted spread: the fraction of held-out errors within ``k`` predicted standard
deviations against ``k``, next to the Gaussian's ``erf(k / sqrt 2)``.
"""

from __future__ import annotations

import numpy as np

from lab.viz.style import GOAL_STYLE, STRATEGY_COLORS, legend_outside, mean_and_range, plain_log_ticks

__all__ = ["STRATEGY_COLORS", "METRIC_LABELS", "plot_error_vs_n", "plot_calibration"]

METRIC_LABELS = {
    "model_error_m": "model error, held-out random commands [mm]",
    "tracking_mean_m": "tracking error, Table I, mean of 3 shapes [mm]",
}


def plot_error_vs_n(panels: dict, metrics=("model_error_m", "tracking_mean_m"), *, goals=None, figsize=None):
    """One row of panels per data set, one column per metric: each strategy's mean over the
    rows of each N against N, log-log, a bar spanning their range (series dodged).

    The strategies keep one colour and one legend order (:data:`STRATEGY_COLORS`) in every
    panel; the one legend sits beside the panels. A panel whose data set lacks a strategy
    that another one has says so in its title ("not run: active").

    Parameters
    ----------
    panels : dict
        ``{title: rows}``, rows being dicts with ``strategy``, ``n`` and the metrics (m, drawn in mm).
    metrics : sequence of str, optional
        The columns drawn, one per panel column.
    goals : dict, optional
        ``{metric: value_m}`` (or ``{metric: (value_m, label)}``, the label unused) drawn as
        horizontal lines, labelled in mm.
    figsize : tuple of float, optional
        Figure size (inches; default from the number of panels).

    Returns
    -------
    tuple
        ``(fig, axes)``: the matplotlib Figure and its (n_data_sets, n_metrics) axes array.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    goals = {k: float(v[0] if isinstance(v, tuple) else v) for k, v in (goals or {}).items()}
    n_rows, n_cols = len(panels), len(metrics)
    fig, axes = plt.subplots(
        n_rows, n_cols, figsize=figsize or (5.0 * n_cols + 1.8, 3.6 * n_rows), layout="constrained", squeeze=False
    )
    seen = {r["strategy"] for rows in panels.values() for r in rows}
    order = [s for s in STRATEGY_COLORS if s in seen] + sorted(seen - set(STRATEGY_COLORS))
    handles: dict = {}
    for row_axes, (title, rows) in zip(axes, panels.items()):
        missing = [s for s in order if s not in {r["strategy"] for r in rows}]
        for ax, metric in zip(row_axes, metrics):
            shown = [s for s in order if any(r["strategy"] == s for r in rows)]
            for k, strategy in enumerate(shown):
                by_n: dict = {}
                for r in rows:
                    v = float(r[metric])
                    if r["strategy"] == strategy and np.isfinite(v):
                        by_n.setdefault(int(r["n"]), []).append(1e3 * v)
                if not by_n:
                    continue
                ns = sorted(by_n)
                color = STRATEGY_COLORS.get(strategy, "k")
                line = mean_and_range(ax, ns, [by_n[n] for n in ns], color=color, k=k, n=len(shown), label=strategy)
                handles.setdefault(strategy, line)
            if metric in goals:
                mm = 1e3 * goals[metric]
                what = METRIC_LABELS.get(metric, metric).split(",")[0]
                handles.setdefault(f"goal {metric}", ax.axhline(mm, **GOAL_STYLE, label=f"goal, {what}: {mm:g} mm"))
            ax.set_xscale("log")
            ax.set_yscale("log")
            plain_log_ticks(ax)
            # the Ns asked for (a grid's safe counts sit next to them and would overlap)
            ns_all = sorted({int(r["n"]) for r in rows if r["strategy"] != "grid"} or {int(r["n"]) for r in rows})
            ax.set_xticks(ns_all, [str(n) for n in ns_all])  # the Ns measured, not 10^k labels
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_xlabel("samples N [samples]")
            ax.set_ylabel(METRIC_LABELS.get(metric, f"{metric.removesuffix('_m')} [mm]"), fontsize=9)
            ax.set_title(title + (f" (not run: {', '.join(missing)})" if missing else ""), fontsize=10)
            ax.grid(alpha=0.3, which="major")
    legend_outside(fig, [handles[s] for s in order if s in handles] + [h for k, h in handles.items() if k not in order])
    return fig, axes


def plot_calibration(curves: dict, k_max: float = 3.0, *, ax=None):
    """Reliability of predicted spreads: the fraction of z <= k against k in [0, ``k_max``]
    for each curve, with the Gaussian reference and its 1- and 2-sigma points.

    Parameters
    ----------
    curves : dict
        ``{label: z}``, z the per-coordinate normalised errors ``|y - mean| / std`` (any shape).
    k_max : float, optional
        Right end of the k axis (standard deviations).
    ax : matplotlib.axes.Axes, optional
        Where to draw (None: a new figure).

    Returns
    -------
    matplotlib.axes.Axes
        The axes.
    """
    import matplotlib.pyplot as plt
    from scipy.special import erf

    if ax is None:
        _, ax = plt.subplots(figsize=(5.2, 4.2), layout="constrained")
    k = np.linspace(0.0, k_max, 200)
    ax.plot(k, erf(k / np.sqrt(2.0)), "k--", lw=1.2, label="Gaussian (calibrated)", gid="reference")
    for (label, z), color in zip(curves.items(), ("C0", "C1", "C2", "C3", "C4")):
        z = np.sort(np.ravel(np.asarray(z, float)))
        ax.plot(k, np.searchsorted(z, k, side="right") / len(z), color=color, lw=1.8, label=label)
    for kk, p in ((1, 0.6827), (2, 0.9545)):
        ax.plot([kk], [p], "ko", ms=4)
    ax.set_xlabel("k: error within k predicted standard deviations [std]")
    ax.set_ylabel("fraction of held-out errors [1]")
    ax.set_xlim(0, k_max)
    ax.set_ylim(0, 1.01)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    return ax
