"""The figures' one standard (docs/figures.md, :mod:`lab.viz.style`), checked on what every
figure function of :mod:`lab.viz` draws from small synthetic data (or a small shipped cache):

* target lines pink and achieved tips near-black (several achieved series: never pink);
* log axes label plain numbers (no 2×10⁻¹ or 10⁰ where "0.2" or "1" fits);
* every axis that shows ticks has a label with a unit in brackets;
* legends lie inside the figure and over no other panel;
* a major grid only (no dense minor grid);
* counting in titles starts at 1;
* spatial panels have equal scales (3-D ones are orthographic);
* each of the paper's references in a panel has its own dash pattern and a label, and a
  reference line's colour means one thing in a figure.

The last tests break each rule on purpose and check that the checks see it.
"""

import re
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import to_rgb  # noqa: E402

from lab.control import trajectories  # noqa: E402
from lab.learn import TrainLog  # noqa: E402
from lab.tracking.track import TrackResult  # noqa: E402
from lab.viz import style  # noqa: E402

DATA = Path(__file__).resolve().parent.parent / "data"
UNIT = re.compile(r"\[[^\]]+\]")
SCIENTIFIC = re.compile(r"10\^|\\times|×|\de[+-]?\d")
SPATIAL = re.compile(r"^[xyz](?: \([a-z]+\))? \[(?:m|cm|mm)\]$")
ZERO_BASED = re.compile(r"(?:^|\s)(?:frame|target|panel|run|robot)\s+0\b|^0:")
REFERENCE_GIDS = ("goal", "limit", "paper", "sim-only")


# ------------------------------------------------------------------ the checks
def _same(c1, c2) -> bool:
    return np.allclose(to_rgb(c1), to_rgb(c2), atol=1e-3)


def roles(fig) -> list[str]:
    """Target and achieved lines in their colours; legend entries named "target..." pink."""
    errors = []
    for ax in fig.axes:
        achieved = [ln for ln in ax.get_lines() if ln.get_gid() == "achieved"]
        for ln in ax.get_lines():
            if ln.get_gid() == "target" and not _same(ln.get_color(), style.TARGET_COLOR):
                errors.append(f"target line {ln.get_label()!r} is {ln.get_color()}")
        for ln in achieved:
            if len(achieved) == 1 and not _same(ln.get_color(), style.ACHIEVED_COLOR):
                errors.append(f"achieved line {ln.get_label()!r} is {ln.get_color()}")
            if _same(ln.get_color(), style.TARGET_COLOR):
                errors.append(f"achieved line {ln.get_label()!r} in the target's pink")
    for legend in _legends(fig):
        for text, handle in zip(legend.get_texts(), legend.legend_handles):
            if text.get_text().startswith("target") and hasattr(handle, "get_color"):
                if not _same(handle.get_color(), style.TARGET_COLOR):
                    errors.append(f"legend entry {text.get_text()!r} is {handle.get_color()}")
    return errors


def has_paths(fig) -> bool:
    gids = {ln.get_gid() for ax in fig.axes for ln in ax.get_lines()}
    return {"target", "achieved"} <= gids


def log_ticks(fig) -> list[str]:
    """No scientific notation on a log axis for a value a plain number says (0.01 to 1000)."""
    errors = []
    for ax in fig.axes:
        if ax.name == "3d":
            continue
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() != "log":
                continue
            lo, hi = sorted(axis.get_view_interval())
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                v, text = tick.get_loc(), tick.label1.get_text()
                if (
                    tick.label1.get_visible()
                    and text
                    and lo <= v <= hi
                    and 0.01 <= v <= 1000
                    and SCIENTIFIC.search(text)
                ):
                    errors.append(f"{ax.get_title()!r}: tick {v:g} labelled {text!r}")
    return errors


def units(fig) -> list[str]:
    """Every axis showing tick labels has a label with a unit in brackets."""
    errors = []
    for ax in fig.axes:
        if not ax.axison:
            continue
        axes = (ax.xaxis, ax.yaxis, ax.zaxis) if ax.name == "3d" else (ax.xaxis, ax.yaxis)
        for axis in axes:
            shown = [t for t in axis.get_ticklabels() if t.get_visible() and t.get_text()]
            if shown and not UNIT.search(axis.get_label_text()):
                errors.append(f"{ax.get_title()!r}: axis label {axis.get_label_text()!r} has no [unit]")
    return errors


def _legends(fig) -> list:
    return list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]


def legends(fig) -> list[str]:
    """Each legend inside the figure, over no panel but its own (a figure's legend: over none)."""
    errors, page = [], fig.bbox
    for legend in _legends(fig):
        box = legend.get_window_extent()
        if box.x0 < page.x0 - 1 or box.x1 > page.x1 + 1 or box.y0 < page.y0 - 1 or box.y1 > page.y1 + 1:
            errors.append(f"legend {[t.get_text() for t in legend.get_texts()][:2]} leaves the figure")
        own = legend.axes if legend not in fig.legends else None
        if _between(fig, box):
            errors.append(f"legend {[t.get_text() for t in legend.get_texts()][:2]} between panels")
        for ax in fig.axes:
            if ax is own or not ax.axison:
                continue
            other = ax.get_window_extent()
            if min(box.x1, other.x1) - max(box.x0, other.x0) > 1 and min(box.y1, other.y1) - max(box.y0, other.y0) > 1:
                errors.append(f"legend {[t.get_text() for t in legend.get_texts()][:2]} over {ax.get_title()!r}")
    return errors


def _between(fig, box) -> bool:
    """Whether the display box ``box`` lies between panels: one left and one right of it at
    its height, or one above and one below it at its width."""
    panels = [ax.get_window_extent() for ax in fig.axes if ax.axison]
    level = [p for p in panels if min(p.y1, box.y1) - max(p.y0, box.y0) > 1]
    column = [p for p in panels if min(p.x1, box.x1) - max(p.x0, box.x0) > 1]
    return (any(p.x1 <= box.x0 + 1 for p in level) and any(p.x0 >= box.x1 - 1 for p in level)) or (
        any(p.y1 <= box.y0 + 1 for p in column) and any(p.y0 >= box.y1 - 1 for p in column)
    )


def grids(fig) -> list[str]:
    """A major grid at most: no minor grid lines."""
    errors = []
    for ax in fig.axes:
        if ax.name != "3d" and ax.axison:
            for axis in (ax.xaxis, ax.yaxis):
                if any(t.gridline.get_visible() for t in axis.get_minor_ticks()):
                    errors.append(f"{ax.get_title()!r}: minor grid")
    return errors


def counting(fig) -> list[str]:
    """Titles count from 1."""
    titles = [ax.get_title() for ax in fig.axes] + [fig._suptitle.get_text() if fig._suptitle else ""]
    return [f"title {t!r} counts from 0" for t in titles if ZERO_BASED.search(t)]


def aspect(fig) -> list[str]:
    """Spatial panels at equal scales (2-D: aspect 1; 3-D: orthographic, box as the limits)."""
    errors = []
    for ax in fig.axes:
        if ax.name == "3d":
            if ax._focal_length != np.inf:
                errors.append(f"{ax.get_title()!r}: 3-D in perspective")
            spans = np.ptp([ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d()], axis=1)
            if not np.allclose(spans / spans.max(), ax._box_aspect / np.max(ax._box_aspect), atol=0.02):
                errors.append(f"{ax.get_title()!r}: 3-D box {ax._box_aspect} for spans {spans}")
        elif ax.axison and "stretched" not in ax.get_title():
            x, y = ax.get_xlabel().splitlines(), ax.get_ylabel().splitlines()
            if x and y and SPATIAL.match(x[-1]) and SPATIAL.match(y[-1]) and ax.get_aspect() != 1.0:
                errors.append(f"{ax.get_title()!r}: {x[-1]} against {y[-1]} at aspect {ax.get_aspect()}")
    return errors


def references(fig) -> list[str]:
    """The paper's references of a panel: each labelled, each its own dash pattern; a
    reference line's colour is no other role's in the figure."""
    errors, colour_of = [], {}
    for ax in fig.axes:
        papers = [ln for ln in ax.get_lines() if ln.get_gid() == "paper"]
        if any(ln.get_label().startswith("_") for ln in papers):
            errors.append(f"{ax.get_title()!r}: a paper reference without a label")
        patterns = [tuple(ln._dash_pattern[1] or ()) for ln in papers]
        if len(set(patterns)) < len(patterns):
            errors.append(f"{ax.get_title()!r}: paper references share a dash pattern")
        for ln in ax.get_lines():
            if ln.get_gid() in REFERENCE_GIDS:
                colour_of.setdefault(to_rgb(ln.get_color()), set()).add(ln.get_gid())
    for rgb, gids in colour_of.items():
        if len(gids) > 1:
            errors.append(f"colour {rgb} means {sorted(gids)}")
    return errors


CHECKS = (roles, log_ticks, units, legends, grids, counting, aspect, references)


def check(fig) -> dict:
    """``{check: errors}`` of every check on ``fig``, drawn once (at a low resolution: the
    checks compare positions, not pixels)."""
    fig.set_dpi(30)
    fig.canvas.draw()
    return {c.__name__: c(fig) for c in CHECKS}


# ------------------------------------------------------------------ small data
def _result(name: str, n: int, seed: int = 0) -> TrackResult:
    t = trajectories.builtin(name, n)
    phase = np.linspace(0, 2 * np.pi, len(t))[:, None]
    u = 1.5 + 1.2 * np.sin(phase + np.array([0.0, 2.1, 4.2]))
    achieved = t + np.random.default_rng(seed).normal(0, 3e-4, t.shape)
    k = len(t)
    ones, zeros = np.ones(k, bool), np.zeros(k)
    errors = np.linalg.norm(achieved - t, axis=1)
    return TrackResult(name, t, u, achieved, t, errors, ones, np.zeros(k, int), ones, zeros, {})


def _transfer_rows() -> list:
    rows = []
    for k in range(3):
        rows.append(
            {"robot": f"random:{k}", "method": "sim-only", "n_real": 0, "tracking_mean_m": 0.01, "model_error_m": 0.011}
        )
        for method in ("real-only", "finetune", "residual", "calibrated"):
            for n in (5, 10, 30, 100, 308):
                if method == "calibrated" and n > 100:
                    continue
                e = 0.02 / (1 + n / 10) * (1 + 0.2 * k)
                rows.append(
                    {
                        "robot": f"random:{k}",
                        "method": method,
                        "n_real": n,
                        "tracking_mean_m": e,
                        "model_error_m": 2 * e,
                    }
                )
    return rows


def _curve_rows(strategies, seeds) -> list:
    return [
        {
            "strategy": s,
            "n": n,
            "model_error_m": 0.01 / n**0.7 * (1 + 0.1 * i + 0.05 * seed),
            "tracking_mean_m": 0.005 / n**0.6,
        }
        for i, s in enumerate(strategies)
        for n in (25, 50, 100, 308)
        for seed in seeds
    ]


def _sweep(offset: float) -> tuple:
    widths = [2, 4, 8, 20, 40]
    runs = [
        {"width": w, "run": r, "test_mean_distance_m": 1e-3 * (offset + abs(w - 12) / 4 + 0.3 * r)}
        for w in widths
        for r in range(4)
    ]
    table = []
    for w in widths:
        v = np.array([r["test_mean_distance_m"] for r in runs if r["width"] == w])
        q25, median, q75 = np.quantile(v, [0.25, 0.5, 0.75])
        table.append(
            {
                "width": w,
                **{
                    f"test_mean_distance_m_{k}": x
                    for k, x in zip(("mean", "median", "q25", "q75"), (v.mean(), median, q25, q75))
                },
            }
        )
    return table, runs, 308


def _train_log() -> TrainLog:
    epochs = np.arange(21)
    history = {"epoch": epochs, **{k: 1e-3 * 0.5**epochs for k in ("perf", "vperf", "tperf")}}
    history |= {"gradient": 1e-2 * 0.6**epochs, "mu": np.maximum(1e-3 * 0.1**epochs, 1e-9)}
    return TrainLog("lm", "min_grad", 20, 20, history, {"min_grad": 1e-6})


def _passes_doc() -> dict:
    t = trajectories.builtin("circle", 40)
    passes = [
        {"pass": p, "achieved": (t + 0.003 / (1 + 3 * p)).tolist(), "mean_error_m": 0.005 / (1 + 3 * p)}
        for p in range(3)
    ]
    return {"targets": t.tolist(), "passes": passes}


def _pass_rows() -> list:
    return [
        {
            "trajectory": traj,
            "model": model,
            "mode": mode,
            "pass": p,
            "mean_error_m": 0.006 / (1 + 2 * p) * (1 + (model == "sim")),
        }
        for mode in ("ilc", "feedback")
        for model in ("real", "sim")
        for traj in ("circle", "square")
        for p in range(4)
    ]


def _figure(name, fem):  # noqa: C901  (one branch per figure function)
    import lab.viz as viz
    from lab.studies.capture_rate import read_capture_rate
    from lab.studies.period_curve import read_period_curve, read_traces

    robot = fem.robot
    if name == "transfer_curve":
        return viz.plot_transfer_curve(_transfer_rows())[0]
    if name == "error_vs_n":
        panels = {
            "FEM, LM": _curve_rows(list(style.STRATEGY_COLORS), (0, 1)),
            "FEM, BR": _curve_rows(["grid", "sobol", "random"], (0,)),
        }
        return viz.plot_error_vs_n(panels, goals={"model_error_m": 0.5e-3, "tracking_mean_m": 1.5e-3})[0]
    if name == "calibration":
        z = np.abs(np.random.default_rng(0).normal(size=(200, 3)))
        return viz.plot_calibration({"ensemble": z, "scaled": 0.8 * z}).figure
    if name == "network_size":
        panels = {"simulated (FEM)": _sweep(0.3), "emulated as-built robot": _sweep(0.5)}
        return viz.plot_network_size(panels, w_cross=24, references={"emulated as-built robot": [(4.42e-3, "paper")]})[
            0
        ]
    if name == "stopping":
        table = [
            {
                "width": w,
                "rules_test_mm": 1 + w / 10,
                "rules_train_mm": 0.5,
                "nograd_test_mm": 2.0,
                "nograd_train_mm": 0.1,
            }
            for w in (8, 40)
        ]
        return viz.plot_stopping(table, n_runs=1)[0]
    if name == "figure3":
        rows = {c: {s: _result(s, 40, i) for s in ("circle", "square", "rose")} for i, c in enumerate(("real", "sim"))}
        return viz.plot_figure3(rows, title="Figure 3")
    if name == "tracking_row":
        return viz.plot_tracking_row({s: _result(s, 40) for s in ("circle", "square")}, robot, title="row")
    if name == "helix":
        return viz.plot_helix(_result("helix", 60), robot)
    if name == "paths_3d":
        return viz.plot_paths_3d({s: _result(s, 40) for s in ("circle", "square", "helix")}, title="Figure 5")
    if name == "square_frames":
        r = _result("square", 16)
        return viz.plot_square_frames(fem, r.targets_W, r.commands, achieved_W=r.achieved_W, title="Figure 2")
    if name == "closed_loop":
        return viz.plot_closed_loop(_pass_rows())[0]
    if name == "passes":
        return viz.plot_passes(_passes_doc(), title="ILC").figure
    if name == "period_curve":
        fig, ax = plt.subplots(figsize=(7.2, 4.6), layout="constrained")
        viz.plot_period_curve(read_period_curve(DATA / "period_curve.csv"), ax)
        return fig
    if name == "streamed_trajectory":
        return viz.plot_streamed_trajectory(read_traces(DATA / "stream_circle_T5.csv")).figure
    if name == "capture_rate":
        fig, ax = plt.subplots(figsize=(6.6, 4.4), layout="constrained")
        viz.plot_capture_rate(read_capture_rate(DATA / "capture_rate.csv"), ax)
        return fig
    if name == "lm_training":
        return viz.plot_lm_training(_train_log(), 246)[0]
    if name == "trajectory_placement":
        shapes = {s: trajectories.builtin(s) for s in trajectories.BUILTIN}
        angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
        return viz.plot_trajectory_placement(shapes, trajectories.CENTRE_W, angles, np.full(12, 0.05))[0]
    if name == "setup":
        return viz.plot_setup(robot)[0]
    if name == "arm_views":
        return viz.plot_arm_views(fem, None, np.array([1.0, 0.5, 0.0]))[0]
    if name == "body_views":
        return viz.plot_body_views(fem, title="body")[0]
    if name == "diagnostics":
        from lab.data import InspectSpec, inspect_dataset

        rng = np.random.default_rng(0)
        u = rng.uniform(-1, 1, (240, 3))
        u[200:] = u[:40] + rng.normal(0, 0.01, (40, 3))
        y = 0.05 * np.column_stack([np.sin(u[:, 0]), np.cos(u[:, 1]), u[:, 2]]) + rng.normal(0, 0.002, (240, 3))
        return viz.plot_diagnostics(inspect_dataset(u, y, None, InspectSpec(bootstrap=5)))[0]
    raise KeyError(name)


FIGURES = (
    "transfer_curve", "error_vs_n", "calibration", "network_size", "stopping", "figure3", "tracking_row", "helix",
    "paths_3d", "square_frames", "closed_loop", "passes", "period_curve", "streamed_trajectory", "capture_rate",
    "lm_training", "trajectory_placement", "setup", "arm_views", "body_views", "diagnostics",
)  # fmt: skip
#: The figures that draw a target and what was achieved.
PATHS = {"figure3", "tracking_row", "helix", "paths_3d", "square_frames", "passes", "streamed_trajectory"}


@pytest.mark.parametrize("name", FIGURES)
def test_figure_meets_the_standard(name, coarse_fem):
    fig = _figure(name, coarse_fem)
    try:
        errors = [e for found in check(fig).values() for e in found]
        assert not errors, f"{name}: " + "; ".join(errors)
        assert has_paths(fig) == (name in PATHS), f"{name}: target and achieved lines marked {has_paths(fig)}"
    finally:
        plt.close(fig)


def test_every_figure_function_is_checked():
    import lab.viz as viz

    # every public plot_* of lab.viz but the two that draw on an axes they are given (arm_views, body_views use them)
    drawn = {n for n in viz.__all__ if n.startswith("plot_")} - {"plot_arm", "plot_body"}
    checked = {"plot_" + n for n in FIGURES}
    assert drawn == checked, sorted(drawn ^ checked)


# ------------------------------------------------------------------ the checks see a broken figure
def test_checks_catch_what_the_reviewer_sent_back():
    fig, (a, b) = plt.subplots(1, 2, figsize=(8, 3.5))
    a.plot([1, 2], [1, 2], color="k", gid="target", label="target")  # target in black
    a.plot([1, 2], [1.1, 2.1], color=style.TARGET_COLOR, gid="achieved", label="achieved")  # achieved in pink
    b.plot([5, 300], [0.2, 3.0])
    b.set_xscale("log")
    b.set_yscale("log")  # matplotlib's 2×10⁻¹ labels
    b.grid(which="both")  # a dense minor grid
    b.axhline(0.5, color="C3", ls=":", gid="paper", label="paper A")
    b.axhline(0.7, color="C3", ls=":", gid="paper", label="paper B")  # one style for two references
    b.axhline(0.25, color="C3", gid="goal", label="goal")  # red: also sim-only below
    b.axhline(1.0, color="C3", ls="--", gid="sim-only", label="sim only")
    b.set_title("target 0 of 8")
    a.set(xlabel="y [cm]", ylabel="z [cm]")  # spatial, but not at equal scales
    b.set_xlabel("N")
    a.legend(loc="upper left", bbox_to_anchor=(0.9, 1.0))  # between the panels
    found = check(fig)
    plt.close(fig)
    assert all(found.values()), [k for k, v in found.items() if not v]
    assert any("target line" in e for e in found["roles"]) and any("pink" in e for e in found["roles"])
    assert any("'N'" in e for e in found["units"])
    assert any("dash pattern" in e for e in found["references"]) and any("means" in e for e in found["references"])


def test_3d_in_perspective_is_caught():
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    ax.plot([0, 1], [0, 2], [0, 1])
    ax.set(xlabel="x [cm]", ylabel="y [cm]", zlabel="z [cm]")
    assert any("perspective" in e for e in aspect(fig))
    ax.set_proj_type("ortho")
    assert any("box" in e for e in aspect(fig))  # default box (4, 4, 3) for spans 1, 2, 1
    plt.close(fig)


def test_plain_log_ticks():
    fig, ax = plt.subplots()
    ax.plot([0.02, 800], [0.2, 3.5])
    ax.set_xscale("log")
    ax.set_yscale("log")
    style.plain_log_ticks(ax)
    fig.canvas.draw()  # (log_ticks reads what a draw labelled)
    labels = {t.get_text() for t in ax.get_yticklabels() + ax.get_yticklabels(minor=True) if t.get_text()}
    assert {"1", "0.3", "2"} <= labels and not log_ticks(fig)
    assert style.PlainLogFormatter()._num_to_string(1e-5, 1e-6, 1) == "1e-5"
    plt.close(fig)
