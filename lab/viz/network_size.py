"""Figure 6 of the paper (chapter 07): test error against the number of neurons per layer.

:func:`plot_network_size` draws, per dataset (one panel each, one shared log axis in mm),
every run of a size sweep (:func:`lab.learn.size_sweep`) as a grey dot, the runs of one
width spread side by side so that none hides another, with the median and interquartile
range and the mean (the paper's statistic) per width. A reference (the paper's number, a
parameter-count threshold) is drawn only in the panels it applies to. :func:`plot_stopping`
draws the ablation of section 3: test and training error with and without the gradient stop.
Both follow :mod:`lab.viz.style`: plain log ticks, a major grid only, legends outside the panels.
"""

from __future__ import annotations

import numpy as np

from lab.viz.style import LIMIT_STYLE, MODEL_COLOR, legend_outside, paper_style, plain_log_ticks

__all__ = ["RUN_SPREAD", "RUN_SPREAD_MAX", "plot_network_size", "plot_stopping"]

#: The runs of one width spread over +- this fraction of the step to the nearer neighbouring
#: width, and at most +- ``RUN_SPREAD_MAX`` neurons (a run stays next to its width).
RUN_SPREAD = 0.3
RUN_SPREAD_MAX = 1.5
MEAN_COLOR = "#ff7f0e"
QUANTITIES = ("mean", "median", "q25", "q75")
MEAN_LABEL = "mean (the paper's statistic)"


def _offsets(n: int, half_width: float) -> np.ndarray:
    """``n`` evenly spaced sideways offsets in [-half_width, half_width] (0 for one run)."""
    return np.linspace(-half_width, half_width, n) if n > 1 else np.zeros(n)


def plot_network_size(panels: dict, *, w_cross=None, references=None, n_layers: int = 2, title: str = ""):
    """Figure 6: mean tip distance on the test set (m, drawn in mm, log axis) against the
    width of the hidden layers, one panel per dataset.

    Parameters
    ----------
    panels : dict
        ``{label: (table, runs, n_samples)}``: the per-width summary rows (``width``,
        ``test_mean_distance_m_{mean,median,q25,q75}``), the per-run rows (``width``, ``run``,
        ``test_mean_distance_m``) and the dataset's number of samples.
    w_cross : int, optional
        The first width with more parameters than training targets, drawn as a dashed limit.
    references : dict, optional
        ``{label: [(value_m, text), ...]}``: horizontal references of the panel ``label``
        only (the paper's number on its real robot belongs in the real robot's panel).
    n_layers : int, optional
        Hidden layers of the networks (for the axis label).
    title : str, optional
        The figure's title.

    Returns
    -------
    tuple
        ``(fig, axes)``: the Figure and its axes, one per panel; the legend is the figure's.
    """
    import matplotlib.pyplot as plt

    references = references or {}
    fig, axes = plt.subplots(
        1, len(panels), figsize=(6.0 * len(panels), 4.6), layout="constrained", sharey=True, squeeze=False
    )
    handles: dict = {}
    for ax, (label, (table, runs, n_samples)) in zip(axes[0], panels.items()):
        widths = np.array([t["width"] for t in table], float)
        gaps = np.diff(widths) if len(widths) > 1 else np.ones(1)
        for j, w in enumerate(widths):
            gap = min(gaps[max(j - 1, 0)], gaps[min(j, len(gaps) - 1)])  # to the nearer neighbour
            mine = sorted((r for r in runs if r["width"] == w), key=lambda r: r["run"])
            x = w + _offsets(len(mine), min(RUN_SPREAD * gap, RUN_SPREAD_MAX))
            y_mm = [1e3 * r["test_mean_distance_m"] for r in mine]
            text = f"each run ({len(mine)} per width, side by side)"
            handles.setdefault("runs", ax.scatter(x, y_mm, s=9, color="0.55", lw=0, zorder=2, label=text))
        q_mm = {k: 1e3 * np.array([t[f"test_mean_distance_m_{k}"] for t in table]) for k in QUANTITIES}
        iqr = "interquartile range of the runs"
        band = ax.fill_between(widths, q_mm["q25"], q_mm["q75"], color=MODEL_COLOR, alpha=0.18, lw=0, label=iqr)
        handles.setdefault("iqr", band)
        (med,) = ax.plot(widths, q_mm["median"], "o-", color=MODEL_COLOR, ms=4, lw=1.7, label="median", zorder=3)
        (mean,) = ax.plot(widths, q_mm["mean"], "s--", color=MEAN_COLOR, ms=3.5, lw=1.4, label=MEAN_LABEL, zorder=3)
        handles.setdefault("median", med)
        handles.setdefault("mean", mean)
        if w_cross is not None and widths.min() <= w_cross <= widths.max():
            text = f"more parameters than training targets (w ≥ {w_cross})"
            handles.setdefault("cross", ax.axvline(w_cross - 0.5, **LIMIT_STYLE, label=text))
        for i, (value_m, text) in enumerate(references.get(label, ())):
            ref = ax.axhline(1e3 * value_m, **paper_style(i), label=f"{text}: {1e3 * value_m:.3g} mm")
            handles.setdefault(text, ref)
        ax.set_yscale("log")
        plain_log_ticks(ax)
        ax.set_xlabel(f"neurons per hidden layer ({n_layers} hidden layers) [neurons]")
        ax.set_title(f"{label}: {n_samples} samples")
        ax.grid(alpha=0.3, which="major")
    axes[0, 0].set_ylabel("mean tip distance on the test set [mm]")
    legend_outside(fig, list(handles.values()), loc="outside lower center", ncol=3)
    if title:
        fig.suptitle(title)
    return fig, axes[0]


def plot_stopping(table, *, n_runs: int, title: str = ""):
    """Section 3's ablation: test and training error (m, drawn in mm, log axis) against the
    width, with the paper's stopping rules and without the gradient stop.

    Parameters
    ----------
    table : list of dict
        One row per width: ``width`` and ``rules_test_mm``, ``rules_train_mm``,
        ``nograd_test_mm``, ``nograd_train_mm`` (mm).
    n_runs : int
        Runs per width (for the title).
    title : str, optional
        The figure's title (default: what it compares and the runs per width).

    Returns
    -------
    tuple
        ``(fig, ax)``: the Figure and its axes.
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9.0, 4.0), layout="constrained")
    w = np.array([t["width"] for t in table])
    rules = (("rules", "o", MODEL_COLOR, "paper's rules"), ("nograd", "s", "#2ca02c", "no gradient stop"))
    for key, marker, color, what in rules:
        test, train = [t[f"{key}_test_mm"] for t in table], [t[f"{key}_train_mm"] for t in table]
        ax.plot(w, test, marker + "-", color=color, label=f"test, {what}")
        ax.plot(w, train, marker + "--", color=color, alpha=0.6, label=f"training, {what}")
    ax.set_yscale("log")
    plain_log_ticks(ax)
    ax.set(xlabel="neurons per hidden layer [neurons]", ylabel="mean tip distance [mm]")
    ax.set_title(title or f"stopping rules vs over-fitting ({n_runs} runs per width)")
    ax.grid(alpha=0.3, which="major")
    legend_outside(fig, ax.get_lines())
    return fig, ax
