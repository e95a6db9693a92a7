"""Figures of the sim-to-real chapter (05): error against the number of real samples.

:func:`plot_transfer_curve` draws, per transfer method, the family mean (line) and the
spread over the robots (band: min to max) of a metric of :mod:`lab.studies.transfer_study`
against N on a log axis; N = 0 (the simulation network alone) is a dashed line. Tracking
panels carry the paper's three Table I rows (mean over circle, square and rose) as
horizontal references. The legend sits beside the first panel, outside the data: the
bands reach into every corner of a panel.
"""

from __future__ import annotations

import numpy as np

__all__ = ["METHOD_COLORS", "PAPER_MEAN_CM", "plot_transfer_curve"]

METHOD_COLORS = {
    "real-only": "C7",
    "finetune": "C0",
    "finetune-last": "C9",
    "residual": "C2",
    "calibrated": "C1",
    "sim-only": "C3",
}


def _paper_means() -> dict:
    from lab.studies.table1 import PAPER_CM

    return {cond: float(np.mean(list(v.values()))) for cond, v in PAPER_CM.items()}


#: Table I of the paper, mean over the three shapes, cm.
PAPER_MEAN_CM = _paper_means()


def plot_transfer_curve(rows, metrics=("tracking_mean_m", "model_error_m"), *, title: str = "", figsize=(12, 4.6)):
    """One panel per metric (m, drawn in cm) against N (log axis): per method the family's
    mean (line) and range (band); the shipped robot, if present, is left out of the family
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
        ``(fig, axes)``: the matplotlib Figure and its axes, one per metric.
    """
    import matplotlib.pyplot as plt

    fam = [r for r in rows if r["robot"] != "shipped"]
    n_robots = len({r["robot"] for r in fam})
    fig, axes = plt.subplots(1, len(metrics), figsize=figsize, layout="constrained", squeeze=False)
    for ax, metric in zip(axes[0], metrics):
        for method in dict.fromkeys(r["method"] for r in fam):
            by_n: dict = {}
            for r in fam:
                if r["method"] == method:
                    by_n.setdefault(r["n_real"], []).append(100 * r[metric])
            color = METHOD_COLORS.get(method, "k")
            if method == "sim-only":
                v = by_n.get(0, [])
                if v:
                    ax.axhline(
                        np.mean(v), color=color, ls="--", lw=1.5, label=f"sim data only (N = 0): {np.mean(v):.2f}"
                    )
                continue
            ns = np.array(sorted(n for n in by_n if n > 0))
            if not len(ns):
                continue
            vals = [np.array(by_n[n]) for n in ns]
            mean = np.array([v.mean() for v in vals])
            ax.plot(ns, mean, "o-", color=color, lw=1.8, ms=4, label=method)
            ax.fill_between(ns, [v.min() for v in vals], [v.max() for v in vals], color=color, alpha=0.12, lw=0)
        if metric.startswith(("tracking", "circle", "square", "rose")):
            for (cond, cm), ls in zip(PAPER_MEAN_CM.items(), (":", "-.", (0, (1, 3)))):
                ax.axhline(cm, color="0.35", ls=ls, lw=1.0, label=f"paper: {cond} ({cm:.2f})")
            ax.axhline(0.25, color="C3", lw=0.8, alpha=0.5, label="goal 0.25")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("real samples N")
        what = "Table I tracking error, mean of circle/square/rose" if metric == "tracking_mean_m" else metric
        if metric == "model_error_m":
            what = "model error on held-out random commands"
        ax.set_ylabel(f"{what} [cm]", fontsize=9)
        ax.grid(alpha=0.3, which="both")
    # beside the first panel, never on it: the bands fill every corner of a panel
    axes[0, 0].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    fig.suptitle(
        title
        or f"Sim-to-real with N real samples: mean (line) and range (band) over {n_robots} emulated as-built robots"
    )
    return fig, axes[0]
