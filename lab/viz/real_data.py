"""The figure of a dataset's diagnostics (``python -m lab inspect``, :mod:`lab.data.diagnostics`).

:func:`plot_diagnostics` draws a report's four measurements on a 2 x 2 grid: the
repeatability floor (pairs' tip difference per row against their command distance, with
the fitted extrapolation to distance 0, whose value is the floor), hysteresis (near
pairs' tip difference against the distance of their previous commands), and drift (the
local-fit residual of blocks of rows against the row index; near pairs' tip difference
against the rows between them). It reads only the report, so a saved JSON report can be
drawn again later.
"""

from __future__ import annotations

import textwrap

import numpy as np

from lab.viz.style import plain_log_ticks

__all__ = ["AXIS_COLORS", "plot_diagnostics"]

#: colours of the x, y, z components
AXIS_COLORS = ("C0", "C2", "C3")


def _binned(x, v, n_bins: int = 10, log: bool = False):
    """Bin centres and RMS of ``v`` in equal-count bins of ``x``."""
    x, v = np.asarray(x, float), np.asarray(v, float)
    if len(x) < 2:
        return np.array([]), np.array([])
    edges = np.unique(np.quantile(x, np.linspace(0, 1, n_bins + 1)))
    which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, max(len(edges) - 2, 0))
    keep = [k for k in range(max(len(edges) - 1, 1)) if np.any(which == k)]
    centre = [np.exp(np.mean(np.log(x[which == k]))) if log else x[which == k].mean() for k in keep]
    return np.array(centre), np.array([np.sqrt(np.mean(v[which == k] ** 2)) for k in keep])


def _mm(v) -> str:
    return "-" if v is None else f"{1e3 * v:.1f}"


def _floor_panel(ax, f: dict) -> None:
    s = f["sample"]
    d = np.sqrt(np.asarray(s["d2"], float))
    per_row = 1e3 * np.asarray(s["dy"], float) / np.sqrt(2)
    exact = np.asarray(s["exact"], bool)
    same = np.asarray(s["same"], bool)
    ax.scatter(
        d[same & ~exact], per_row[same & ~exact], s=4, color="C0", alpha=0.25, lw=0, label="pairs, same sequence"
    )
    ax.scatter(d[~same & ~exact], per_row[~same & ~exact], s=4, color="C1", alpha=0.25, lw=0, label="pairs, across")
    if exact.any():
        jitter = 0.004 * (np.arange(exact.sum()) % 5)
        ax.scatter(jitter, per_row[exact], s=10, marker="x", color="k", lw=0.8, label="exact revisits")
    b = f["bins"]
    if b["d2"]:
        ax.plot(np.sqrt(b["d2"]), 1e3 * np.sqrt(np.asarray(b["dy2_m2"]) / 2), "s", color="0.2", ms=5, label="bin RMS")
    if f.get("intercept_m2") is not None and f.get("slope_m2") is not None:
        grid = np.linspace(0, max(d.max(initial=0.0), 1e-9), 100)
        fit = np.sqrt(np.maximum(f["intercept_m2"] + f["slope_m2"] * grid**2, 0) / 2)
        ax.plot(grid, 1e3 * fit, "-", color="k", lw=1.5, label="fit sqrt((a + b d^2) / 2)")
    if f.get("floor_m") is not None:
        lo, hi = f["interval_m"] or (f["floor_m"], f["floor_m"])
        ax.errorbar([0], [1e3 * f["floor_m"]], yerr=[[1e3 * (f["floor_m"] - lo)], [1e3 * (hi - f["floor_m"])]],
                    fmt="o", color="C3", ms=6, capsize=3, zorder=5, label=f"floor {_mm(f['floor_m'])} mm")  # fmt: skip
    top = np.quantile(per_row, 0.97) if len(per_row) else 1.0
    ax.set_ylim(0, 1.15 * max(top, 1e3 * (f.get("floor_m") or 0)))
    ax.set_xlim(left=-0.01)
    ax.set_xlabel("command distance d (each motor scaled to its range) [1]")
    ax.set_ylabel("tip difference per row |y_i - y_j| / sqrt 2 [mm]")
    ax.set_title(
        f"repeatability floor {_mm(f.get('floor_m'))} mm; {f['n_pairs']} pairs, {f['n_exact_pairs']} exact", fontsize=9
    )
    ax.legend(fontsize=7, loc="upper left", markerscale=2)
    notes = [textwrap.fill("caution: " + c, 70) for c in f.get("cautions") or []]
    if notes:
        ax.text(0.98, 0.02, "\n".join(notes), transform=ax.transAxes, ha="right", va="bottom", fontsize=7, color="C3",
                bbox={"facecolor": "white", "alpha": 0.85, "lw": 0})  # fmt: skip


def _hysteresis_panel(ax, h: dict, unit: str) -> None:
    if h.get("fraction_explained") is None:
        ax.text(0.5, 0.5, f"hysteresis not measured:\n{h.get('reason')}", ha="center", va="center", fontsize=9)
        ax.set_axis_off()
        return
    s = h["sample"]
    x, dy = np.asarray(s["previous_distance"], float), 1e3 * np.asarray(s["dy"], float)
    ax.scatter(x, dy, s=4, color="C0", alpha=0.25, lw=0, label="near pairs")
    cx, rms = _binned(x, dy)
    ax.plot(cx, rms, "s-", color="0.2", ms=4, label="bin RMS |y_i - y_j|")
    cx, part = _binned(x, 1e3 * np.asarray(s["dy_explained"], float))
    ax.plot(cx, part, "o-", color="C3", ms=4, label="bin RMS of the previous-command term")
    ax.set_ylim(0, 1.15 * np.quantile(dy, 0.97))
    ax.set_xlabel(f"distance of the previous commands |u_(i-1) - u_(j-1)| [{unit}]")
    ax.set_ylabel("tip difference of the pair [mm]")
    ax.set_title(
        f"hysteresis: previous command explains {100 * h['fraction_explained']:.1f} % (p = {h['p_value']:.3f}); "
        f"slope {_mm(h['slope_m_per_unit'])} mm per {unit}",
        fontsize=9,
    )
    ax.legend(fontsize=7, loc="upper left", markerscale=2)


def _drift_panel(ax, d: dict) -> None:
    b = d["blocks"]
    rows, res, seq = np.asarray(b["row"]), 1e3 * np.asarray(b["residual_m"]).reshape(-1, 3), np.asarray(b["sequence"])
    start, stop = np.asarray(b["start"]), np.asarray(b["stop"])
    for s in np.unique(seq):
        if s % 2:
            ax.axvspan(start[seq == s].min(), stop[seq == s].max(), color="0.92", lw=0)
    for k, name in enumerate("xyz"):
        ax.plot(rows, res[:, k], "o", ms=3.5, color=AXIS_COLORS[k], label=f"{name}")
    ax.axhline(0, color="0.5", lw=0.8)
    rate = d.get("rate_m_per_1000_rows")
    words = "not measured" if rate is None else f"{_mm(rate)} mm per 1000 rows [{', '.join(map(_mm, d['interval']))}]"
    if rate is not None and d.get("row_index_r2_from_command", 0) > 0.5:
        words += "\n(row order follows the commands: confounded)"
    ax.set_title(f"drift within sequences: {words}", fontsize=9)
    ax.set_xlabel("row (measurement order; shading: alternate sequences) [1]")
    ax.set_ylabel(f"mean local-fit residual per block [mm] ({d['fit']})")
    ax.legend(fontsize=7, title="component", title_fontsize=7)


def _gap_panel(ax, d: dict) -> None:
    s = d["pairs_sample"]
    gap, dy = np.asarray(s["gap_rows"], float), 1e3 * np.asarray(s["dy_m"], float)
    if not len(gap):
        ax.text(0.5, 0.5, "no near pairs within a sequence", ha="center", va="center", fontsize=9)
        ax.set_axis_off()
        return
    ax.scatter(gap, dy, s=4, color="C0", alpha=0.25, lw=0, label="near pairs, same sequence")
    cx, rms = _binned(gap, dy, log=True)
    ax.plot(cx, rms, "s-", color="0.2", ms=4, label="bin RMS")
    ax.set_xscale("log")
    plain_log_ticks(ax, "x")
    ax.set_ylim(0, 1.15 * np.quantile(dy, 0.97))
    slope = d.get("pairs_gap_m2_per_1000_rows")
    text = "-" if slope is None else f"{1e3 * slope:+.2g} mm^2 per row"
    ax.set_title(f"near pairs against the rows between them: |y_i - y_j|^2 rises {text}", fontsize=9)
    ax.set_xlabel("rows between the pair (time) [rows]")
    ax.set_ylabel("tip difference of the pair [mm]")
    ax.legend(fontsize=7, loc="upper left", markerscale=2)


def plot_diagnostics(report: dict, *, title: str = "", figsize=(12, 8.5)):
    """Draw a report of :func:`lab.data.diagnostics.inspect_dataset` (lengths in m, drawn
    in mm) on a 2 x 2 grid: floor, hysteresis, drift of blocks, pairs against time.

    Parameters
    ----------
    report : dict
        The report (or its saved JSON, loaded).
    title : str, optional
        The figure's title.
    figsize : tuple of float, optional
        Figure size (inches).

    Returns
    -------
    tuple
        ``(fig, axes)``: the matplotlib Figure and its (2, 2) axes array.
    """
    import matplotlib.pyplot as plt

    unit = (report.get("dataset") or {}).get("u_unit") or "unit"
    fig, axes = plt.subplots(2, 2, figsize=figsize, layout="constrained")
    _floor_panel(axes[0, 0], report["floor"])
    _hysteresis_panel(axes[0, 1], report["hysteresis"], unit)
    _drift_panel(axes[1, 0], report["drift"])
    _gap_panel(axes[1, 1], report["drift"])
    for ax in axes.flat:
        ax.grid(alpha=0.3, which="major")
    o = report["outliers"]
    fig.suptitle(
        title
        or f"What a static model can reach: {report['n_rows']} rows, {report['n_sequences']} sequence(s), "
        f"{o['count']} outliers beyond {_mm(o['threshold_m'])} mm",
        fontsize=11,
    )
    return fig, axes
