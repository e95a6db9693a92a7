"""Figures of the sim-to-real chapter (05): error against the number of real samples.

:func:`plot_transfer_curve` draws, per transfer method, the family mean (line and markers)
and the spread over the robots (a vertical bar from the best to the worst robot) of a
metric of :mod:`lab.studies.transfer_study` against N on a log axis. The bars of the
methods sit side by side at each N (dodged), so that none hides another; bands of five
methods on top of one another turned into one brown area. N = 0 (the simulation network
alone) is a red dashed line. Tracking panels carry the paper's three Table I rows (mean
over circle, square and rose), each with its own dash pattern, and the chapter's goal.
A method run to a smaller largest N than the others says so in its legend entry. The one
legend sits beside the panels, never between them (:mod:`lab.viz.style`).
"""

from __future__ import annotations

import numpy as np

from lab.viz.style import (
    GOAL_STYLE,
    METHOD_COLORS,
    SIM_ONLY_STYLE,
    legend_outside,
    mean_and_range,
    paper_style,
    plain_log_ticks,
)

__all__ = ["METHOD_COLORS", "PAPER_MEAN_CM", "GOAL_CM", "plot_transfer_curve"]

#: The chapter's goal for the Table I tracking error (cm).
GOAL_CM = 0.25
Y_LABELS = {
    "tracking_mean_m": "Table I tracking error, mean of circle/square/rose [cm]",
    "model_error_m": "model error on held-out random commands [cm]",
}


def _paper_means() -> dict:
    from lab.studies.table1 import PAPER_CM

    return {cond: float(np.mean(list(v.values()))) for cond, v in PAPER_CM.items()}


#: Table I of the paper, mean over the three shapes, cm.
PAPER_MEAN_CM = _paper_means()


def _by_method(fam: list, metric: str) -> dict:
    """``{method: {n_real: [metric of each robot, cm]}}`` in the rows' order."""
    out: dict = {}
    for r in fam:
        out.setdefault(r["method"], {}).setdefault(r["n_real"], []).append(100 * r[metric])
    return out


def plot_transfer_curve(rows, metrics=("tracking_mean_m", "model_error_m"), *, title: str = "", figsize=(13.5, 4.8)):
    """One panel per metric (m, drawn in cm) against N (log axis): per method the family's
    mean (line) and range (bar); the shipped robot, if present, is left out of the family
    statistics.

    Parameters
    ----------
    rows : list of dict
        Rows of a transfer curve: ``robot``, ``method``, ``n_real`` and the metrics (m).
    metrics : sequence of str, optional
        The columns drawn, one panel each.
    title : str, optional
        The figure's title (default: a description with the number of robots).
    figsize : tuple of float, optional
        Figure size (inches).

    Returns
    -------
    tuple
        ``(fig, axes)``: the matplotlib Figure and its axes, one per metric; the legend is
        the figure's (``fig.legends[0]``), beside the last panel.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    fam = [r for r in rows if r["robot"] != "shipped"]
    n_robots = len({r["robot"] for r in fam})
    n_top = max((r["n_real"] for r in fam), default=0)
    fig, axes = plt.subplots(1, len(metrics), figsize=figsize, layout="constrained", squeeze=False)
    handles: dict = {}
    for ax, metric in zip(axes[0], metrics):
        methods = _by_method(fam, metric)
        data_methods = [m for m in methods if m != "sim-only"]
        for k, method in enumerate(data_methods):
            by_n = methods[method]
            ns = np.array(sorted(n for n in by_n if n > 0))
            if not len(ns):
                continue
            color = METHOD_COLORS.get(method, "k")
            label = method if ns.max() == n_top else f"{method} (run to N = {ns.max()} only)"
            line = mean_and_range(ax, ns, [by_n[n] for n in ns], color=color, k=k, n=len(data_methods), label=label)
            handles.setdefault(label, line)
        if methods.get("sim-only", {}).get(0):
            v = np.mean(methods["sim-only"][0])
            handles.setdefault(
                "sim-only", ax.axhline(v, **SIM_ONLY_STYLE, label=f"sim data only (N = 0): {v:.2f} cm", zorder=1)
            )
        if metric.startswith(("tracking", "circle", "square", "rose")):
            for i, (cond, cm) in enumerate(PAPER_MEAN_CM.items()):
                ref = ax.axhline(cm, **paper_style(i), label=f"paper: {cond} ({cm:.2f} cm)", zorder=1)
                handles.setdefault(cond, ref)
            handles.setdefault("goal", ax.axhline(GOAL_CM, **GOAL_STYLE, label=f"goal {GOAL_CM} cm", zorder=1))
        ax.set_xscale("log")
        ax.set_yscale("log")
        plain_log_ticks(ax)
        ns_all = sorted({r["n_real"] for r in fam if r["n_real"] > 0})
        ax.set_xticks(ns_all, [str(n) for n in ns_all])  # the Ns measured
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("real samples N [samples]")
        ax.set_ylabel(Y_LABELS.get(metric, f"{metric.removesuffix('_m')} [cm]"))
        ax.grid(alpha=0.3, which="major")
    legend_outside(fig, list(handles.values()))
    fig.suptitle(
        title
        or f"Sim-to-real with N real samples: mean (line) and range (bar) over {n_robots} emulated as-built robots"
    )
    return fig, axes[0]
