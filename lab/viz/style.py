"""The figures' one visual standard (docs/figures.md): colours, reference lines, tick
formats and legends, in one place so that every figure function draws the same way.

* **Colours of roles.** The target is pink (:data:`TARGET_COLOR`, the paper's) and what the
  robot achieved near-black (:data:`ACHIEVED_COLOR`) in every figure; a model's prediction is
  blue (:data:`MODEL_COLOR`); the simulation-trained network alone (N = 0) is red
  (:data:`SIM_ONLY_COLOR`). Lines of those roles carry the role as their ``gid`` (the
  ``*_kw`` helpers), so a test can find them.
* **References.** Each of the paper's numbers drawn as a line gets its own dash pattern in
  one grey (:func:`paper_style`) and a legend entry naming it; a goal is thin, solid and
  black (:data:`GOAL_STYLE`); a limit of the hardware (u_max) or a threshold is a light grey
  dashed line (:data:`LIMIT_STYLE`), labelled too.
* **Categories** (cables, transfer methods, sampling strategies) keep one colour each across
  every figure that shows them (:data:`CABLE_COLORS`, :data:`METHOD_COLORS`,
  :data:`STRATEGY_COLORS`).
* **Spread** of several series in one panel: a vertical bar from the smallest to the largest
  value at each x, the series dodged side by side (:func:`mean_and_range`); translucent bands
  of more than two series on top of one another turn into one muddy area.
* **Log axes** show plain numbers, 0.3 and 20, not 3×10⁻¹ (:func:`plain_log_ticks`).
"""

from __future__ import annotations

from matplotlib.ticker import LogFormatter

__all__ = [
    "TARGET_COLOR",
    "ACHIEVED_COLOR",
    "MODEL_COLOR",
    "SIM_ONLY_COLOR",
    "PAPER_COLOR",
    "CABLE_COLORS",
    "SERIES_COLORS",
    "METHOD_COLORS",
    "STRATEGY_COLORS",
    "PAPER_DASHES",
    "GOAL_STYLE",
    "LIMIT_STYLE",
    "SIM_ONLY_STYLE",
    "PANEL_IN",
    "TICK_PT",
    "target_kw",
    "achieved_kw",
    "paper_style",
    "PlainLogFormatter",
    "plain_log_ticks",
    "legend_outside",
    "mean_and_range",
]

#: The target: pink, as the paper draws its targets (Figs. 2-4).
TARGET_COLOR = "#e377c2"
#: What the robot achieved (its measured or simulated tip): near-black.
ACHIEVED_COLOR = "0.15"
#: A model's prediction (the learned network's tip).
MODEL_COLOR = "#1f77b4"
#: The simulation-trained network used alone on the real robot (N = 0 real samples).
SIM_ONLY_COLOR = "#d62728"
#: The paper's reference numbers: one grey, told apart by :data:`PAPER_DASHES`.
PAPER_COLOR = "0.35"
#: One colour per cable (cable i -> CABLE_COLORS[i % 6]); tab10's first six.
CABLE_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")
#: Several achieved series in one panel (runs, passes): tab10 without its pink, grey and red.
SERIES_COLORS = ("#ff7f0e", "#2ca02c", "#1f77b4", "#9467bd", "#8c564b", "#17becf", "#bcbd22")
#: Chapter 05's transfer methods (sim-only shares :data:`SIM_ONLY_COLOR`).
METHOD_COLORS = {
    "real-only": "#7f7f7f",
    "finetune": "#1f77b4",
    "finetune-last": "#17becf",
    "residual": "#2ca02c",
    "calibrated": "#ff7f0e",
    "sim-only": SIM_ONLY_COLOR,
}
#: Chapter 08's sampling strategies.
STRATEGY_COLORS = {
    "grid": "#d62728",
    "sobol": "#1f77b4",
    "lhs": "#2ca02c",
    "maximin": "#9467bd",
    "random": "#7f7f7f",
    "active": "#ff7f0e",
}
#: Dash patterns of the paper's references, one per reference in the order drawn: dotted,
#: dash-dot, long dashes, dash-dot-dot (none of them a goal's solid line or a limit's dashes).
PAPER_DASHES = ((0, (1, 2)), (0, (7, 2, 1, 2)), (0, (12, 4)), (0, (7, 2, 1, 2, 1, 2)))
#: A goal the chapter sets: thin, solid, black.
GOAL_STYLE = {"color": "k", "ls": "-", "lw": 0.9, "gid": "goal"}
#: A limit or threshold (u_max, a parameter count): light grey, dashed.
LIMIT_STYLE = {"color": "0.55", "ls": (0, (4, 3)), "lw": 0.9, "gid": "limit"}
#: The simulation-trained network alone, as a horizontal reference: red, dashed.
SIM_ONLY_STYLE = {"color": SIM_ONLY_COLOR, "ls": "--", "lw": 1.6, "gid": "sim-only"}
#: One 2-D panel's size (width, height) in inches; a figure is a multiple of it.
PANEL_IN = (4.2, 3.3)
#: Font size (pt) of tick labels: legible at a notebook's width (about 1000 px for 12-16 in).
TICK_PT = 9


def target_kw(**kw) -> dict:
    """Keyword arguments of a target line: its colour, ``gid="target"`` and a label.

    Parameters
    ----------
    **kw
        More keyword arguments of ``Axes.plot`` (they win over the defaults).

    Returns
    -------
    dict
        ``color``, ``gid``, ``label`` and ``kw``.
    """
    return {"color": TARGET_COLOR, "gid": "target", "label": "target", **kw}


def achieved_kw(**kw) -> dict:
    """Keyword arguments of an achieved-tip line: its colour, ``gid="achieved"`` and a label.

    Parameters
    ----------
    **kw
        More keyword arguments of ``Axes.plot`` (they win: several achieved series pass a
        colour of :data:`SERIES_COLORS`).

    Returns
    -------
    dict
        ``color``, ``gid``, ``label`` and ``kw``.
    """
    return {"color": ACHIEVED_COLOR, "gid": "achieved", "label": "achieved", **kw}


def paper_style(i: int) -> dict:
    """Style of a panel's ``i``-th paper reference.

    Parameters
    ----------
    i : int
        The reference's place among the panel's paper references (0-based).

    Returns
    -------
    dict
        ``color`` (:data:`PAPER_COLOR`), ``ls`` (its own dash pattern of :data:`PAPER_DASHES`),
        ``lw`` and ``gid="paper"``.
    """
    return {"color": PAPER_COLOR, "ls": PAPER_DASHES[i % len(PAPER_DASHES)], "lw": 1.2, "gid": "paper"}


class PlainLogFormatter(LogFormatter):
    """Log-axis tick labels as plain numbers (``0.02``, ``0.5``, ``20``, ``300``) between
    0.001 and 10,000; outside that, ``1e-05``. Which ticks get a label is
    :class:`matplotlib.ticker.LogFormatter`'s rule (decades; also 2, 3, 5 ... over a short
    range).

    Parameters
    ----------
    *args, **kwargs
        Those of :class:`matplotlib.ticker.LogFormatter` (``labelOnlyBase``,
        ``minor_thresholds``, ...).
    """

    def _num_to_string(self, x, vmin, vmax):
        if 1e-3 <= x < 1e4:
            return f"{x:.6g}"
        return f"{x:.0e}".replace("e-0", "e-").replace("e+0", "e")


def plain_log_ticks(ax, which: str = "both") -> None:
    """Plain-number tick labels on the log axes of ``ax``; call it after
    ``set_xscale``/``set_yscale``, which reset the formatters.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes (its log and symlog axes get the formatter; a linear one is left alone).
    which : str, optional
        ``"x"``, ``"y"`` or ``"both"``.
    """
    axes = {"x": [ax.xaxis], "y": [ax.yaxis], "both": [ax.xaxis, ax.yaxis]}[which]
    for axis in axes:
        if axis.get_scale() in ("log", "symlog"):
            axis.set_major_formatter(PlainLogFormatter())
            axis.set_minor_formatter(PlainLogFormatter(labelOnlyBase=False, minor_thresholds=(1.2, 0.5)))


def legend_outside(fig, handles, *, loc: str = "outside right center", **kw):
    """One legend for the whole figure, outside every panel (constrained layout makes room
    for it).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (constrained layout).
    handles : sequence of matplotlib.artist.Artist
        The entries, in order, each with its label.
    loc : str, optional
        ``"outside right center"`` (beside the panels, clear of the title) or
        ``"outside lower center"`` (below them).
    **kw
        More keyword arguments of ``Figure.legend`` (e.g. ``ncol``).

    Returns
    -------
    matplotlib.legend.Legend
        The legend.
    """
    kw = {"fontsize": TICK_PT, "frameon": False, **kw}
    return fig.legend(handles=handles, loc=loc, **kw)


#: Horizontal offset factor between neighbouring series at one x (log axis), :func:`mean_and_range`.
DODGE = 1.04


def mean_and_range(ax, x, values, *, color, k: int = 0, n: int = 1, label: str = "", log_x: bool = True):
    """One series of a panel of ``n``: the mean of ``values`` at each ``x`` (line and markers)
    and their range (a vertical bar), shifted sideways by its place ``k`` (0-based) among the
    ``n`` so that no bar hides another (by a factor on a log x axis, by a fraction of the
    spacing of ``x`` on a linear one); a series without spread stays at its ``x``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Where to draw.
    x : array_like, shape (K,)
        Positions (any unit), increasing.
    values : sequence of array_like
        The values at each position (any unit; each one or more).
    color : str
        The series' colour.
    k, n : int, optional
        The series' place among the panel's series, and their number.
    label : str, optional
        Legend label of the line.
    log_x : bool, optional
        Whether the x axis is logarithmic.

    Returns
    -------
    matplotlib.lines.Line2D
        The mean's line.
    """
    import numpy as np

    x = np.asarray(x, float)
    vals = [np.atleast_1d(np.asarray(v, float)) for v in values]
    spread = any(v.max() > v.min() for v in vals)
    shift = k - (n - 1) / 2 if spread else 0.0  # a series without bars stays where it was measured
    if log_x:
        xs = x * DODGE**shift
    else:
        step = np.min(np.diff(x)) if len(x) > 1 else 1.0
        xs = x + 0.08 * step * shift
    (line,) = ax.plot(xs, [v.mean() for v in vals], "o-", color=color, lw=1.7, ms=4.5, label=label, zorder=3)
    if spread:
        lo, hi = np.array([v.min() for v in vals]), np.array([v.max() for v in vals])
        ax.vlines(xs, lo, hi, color=color, lw=1.2, alpha=0.75, zorder=2)
    return line
