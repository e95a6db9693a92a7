"""More figures a reviewer found wrong, checked on what they draw (the shipped caches where a
figure draws one): the capture-rate figure's tolerance labels do not overlap; the legends of
the transfer curve, the period curve and the streamed trajectory sit clear of every line,
marker and band; chapter 04's cable key is an axes of its own, beside the data, with legible
text; the helix's 3-D axes carry few enough ticks to read."""

from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PathCollection, PolyCollection  # noqa: E402

from lab.control import trajectories  # noqa: E402
from lab.description import load_robot  # noqa: E402
from lab.studies import read_curve  # noqa: E402
from lab.studies.capture_rate import read_capture_rate  # noqa: E402
from lab.studies.period_curve import read_period_curve, read_traces  # noqa: E402
from lab.tracking.track import TrackResult  # noqa: E402
from lab.viz import plot_capture_rate, plot_helix, plot_tracking_row, plot_transfer_curve  # noqa: E402
from lab.viz.dynamics import plot_period_curve, plot_streamed_trajectory  # noqa: E402

DATA = Path(__file__).resolve().parent.parent / "data"
NOTEBOOK_PX = 1000  # the width (px) JupyterLab shows a figure at


def _line_points(line, step_px: float = 2.0) -> np.ndarray:
    """Display points (K, 2) along a drawn line: its markers, and its segments sampled every
    ``step_px`` (an axhline has only its two ends as data)."""
    xy = line.get_transform().transform(np.column_stack(line.get_data()).astype(float))
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    if line.get_linestyle() in ("None", "none", "") or len(xy) < 2:
        return xy
    out = [xy[:1]]
    for a, b in zip(xy[:-1], xy[1:]):
        n = max(int(np.hypot(*(b - a)) / step_px), 1)
        out.append(a + np.linspace(0, 1, n + 1)[1:, None] * (b - a))
    return np.vstack(out)


def _data_in(ax, box) -> list[str]:
    """What of ``ax``'s data lies inside the display box ``box``: line and marker points,
    scatter offsets, and bands (a band covering a point of the box)."""
    hits = []
    for line in ax.get_lines():
        pts = _line_points(line)
        if len(pts) and np.any(_inside(box, pts)):
            hits.append(f"line {line.get_label()!r}")
    grid = np.stack(np.meshgrid(np.linspace(box.x0, box.x1, 9), np.linspace(box.y0, box.y1, 5)), -1).reshape(-1, 2)
    for coll in ax.collections:
        if isinstance(coll, PathCollection):
            pts = coll.get_offset_transform().transform(coll.get_offsets())
            if np.any(_inside(box, pts)):
                hits.append(f"markers {coll.get_label()!r}")
        elif isinstance(coll, PolyCollection):
            for path in coll.get_paths():
                if np.any(path.contains_points(grid, transform=coll.get_transform())):
                    hits.append(f"band {coll.get_label()!r}")
    return hits


def _inside(box, pts: np.ndarray) -> np.ndarray:
    return (pts[:, 0] > box.x0) & (pts[:, 0] < box.x1) & (pts[:, 1] > box.y0) & (pts[:, 1] < box.y1)


def _assert_legend_clear(fig, legend) -> None:
    """The legend is inside the figure and covers no data of any axes of it."""
    fig.canvas.draw()
    box = legend.get_window_extent()
    page = fig.bbox
    assert page.x0 - 1 <= box.x0 and box.x1 <= page.x1 + 1 and page.y0 - 1 <= box.y0 and box.y1 <= page.y1 + 1
    for ax in fig.axes:
        assert not _data_in(ax, box), (ax.get_title(), _data_in(ax, box))


def test_capture_rate_tolerance_labels_do_not_overlap():
    rows = read_capture_rate(DATA / "capture_rate.csv")  # predictive at 0.25 and 0.4 mm: nearly one point
    fig, ax = plt.subplots(figsize=(6.6, 4.4), layout="constrained")  # as chapter 09 draws it
    plot_capture_rate(rows, ax)
    fig.canvas.draw()
    labels = [t for t in ax.texts if t.get_text()]
    boxes = [t.get_window_extent() for t in labels]
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1 :]), [t.get_text() for t in labels]
    shown = sorted(float(v) for t in labels for v in t.get_text().split(", "))
    swept = sorted(1e3 * r["tol_m"] for r in rows if r["robot"] == "shipped")  # every tolerance still labelled
    np.testing.assert_allclose(shown, swept)
    plt.close(fig)


@pytest.mark.parametrize("name", ["transfer_curve.csv", "transfer_curve_foam.csv"])
def test_transfer_curve_legend_clear_of_the_data(name):
    fig, axes = plot_transfer_curve(read_curve(DATA / name))
    (legend,) = fig.legends  # one legend, the figure's, beside the panels
    assert "goal 0.25 cm" in [t.get_text() for t in legend.get_texts()]  # the goal's label: a legend entry
    assert not [t for t in axes[0].texts if t.get_text()]  # ... not a text in the margin
    _assert_legend_clear(fig, legend)
    plt.close(fig)


def test_period_curve_legend_clear_of_the_data():
    rows = read_period_curve(DATA / "period_curve.csv")  # ten curves: they fill every corner
    fig, ax = plt.subplots(figsize=(7.2, 4.6), layout="constrained")  # as chapter 09 draws it
    plot_period_curve(rows, ax)
    legends = fig.legends + [ax.get_legend()] * (ax.get_legend() is not None)
    assert len(legends) == 1
    texts = [t.get_text() for t in legends[0].get_texts()]
    assert {"open-loop", "feed-forward", "goal"} <= set(texts)  # styles explained once, not per curve
    assert len(texts) == len({(r["rig"], r["model"]) for r in rows}) + 3
    _assert_legend_clear(fig, legends[0])
    plt.close(fig)


def test_streamed_trajectory_legend_clear_of_the_shape():
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.8), layout="constrained")  # chapter 09's left panel
    plot_streamed_trajectory(read_traces(DATA / "stream_circle_T5.csv"), axes[0])
    _assert_legend_clear(fig, axes[0].get_legend())
    plt.close(fig)


def _result(name: str, n: int | None = None, seed: int = 0) -> TrackResult:
    t = trajectories.builtin(name, n)
    phase = np.linspace(0, 2 * np.pi, len(t))[:, None]
    u = 1.5 + 1.4 * np.sin(phase + np.array([0.0, 2.1, 4.2]))  # up to 2.9 of u_max 3: no headroom for a key
    rng = np.random.default_rng(seed)
    k = len(t)
    achieved = t + rng.normal(0, 3e-4, t.shape)
    ones, zeros = np.ones(k, bool), np.zeros(k)
    return TrackResult(name, t, u, achieved, t, zeros, ones, np.zeros(k, int), ones, zeros, {})


def _data_axes(fig):
    return [ax for ax in fig.axes if ax.get_lines() and ax.get_xlabel() in ("y [cm]", "x [cm]", "target number [1]")]


def test_tracking_row_keys_sit_beside_the_data():
    robot = load_robot("three-cable")
    fig = plot_tracking_row({k: _result(k, 40) for k in ("circle", "square", "rose")}, robot, title="row")
    fig.canvas.draw()
    data = _data_axes(fig)
    assert len(data) == 6
    for ax in data:  # no other axes over a data panel (the cable key was an inset on the circle)
        assert not ax.child_axes
        box = ax.get_window_extent()
        others = [o for o in fig.axes if o is not ax and o.get_window_extent().overlaps(box)]
        assert not others, [o.get_title() for o in others]
        if ax.get_legend() is not None:
            _assert_legend_clear(fig, ax.get_legend())
    key = [ax for ax in fig.axes if ax.get_title().startswith("cables")]
    assert len(key) == 1
    names = [t.get_text() for t in key[0].get_legend().get_texts()]
    assert names == [c.name for c in robot.cables]
    _assert_legible(fig, [key[0].title, *key[0].get_legend().get_texts()])
    plt.close(fig)


def _assert_legible(fig, texts) -> None:
    width_in = fig.get_size_inches()[0]
    for t in texts:  # 9 pt, and 8 px at the notebook's width (the key's label was 6 pt)
        px = t.get_fontsize() / 72 * NOTEBOOK_PX / width_in
        assert t.get_fontsize() >= 9 and px >= 8, (t.get_text(), t.get_fontsize(), px)


def test_helix_ticks_and_key_legible():
    robot = load_robot("three-cable")
    fig = plot_helix(_result("helix"), robot, title="helix")
    fig.canvas.draw()
    ax3 = next(ax for ax in fig.axes if ax.name == "3d")
    for axis, lim in ((ax3.xaxis, ax3.get_xlim()), (ax3.yaxis, ax3.get_ylim()), (ax3.zaxis, ax3.get_zlim())):
        ticks = [v for v in axis.get_majorticklocs() if lim[0] <= v <= lim[1]]
        assert 2 <= len(ticks) <= 4, ticks  # x had six: "16 17 18 19 20 21" ran together
        assert all(float(v).is_integer() for v in ticks), ticks
    key = [ax for ax in fig.axes if ax.get_title().startswith("cables")]
    assert len(key) == 1
    _assert_legible(fig, [key[0].title, *key[0].get_legend().get_texts()])
    for ax in _data_axes(fig):  # the key beside the commands, not an inset over them
        assert not ax.child_axes and not key[0].get_window_extent().overlaps(ax.get_window_extent())
    plt.close(fig)
