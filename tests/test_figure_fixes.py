"""The figures a student found wrong, checked on what they draw: Figure 1's labels stay in
their axes and its spools do not overlap; Figure 2's 3-D tick labels are legible at a
notebook's width; chapter 04's side view shows every trajectory; chapter 03's training
figure has integer epoch ticks; the stop message reads as one sentence."""

from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import to_rgb  # noqa: E402

from lab.control import trajectories  # noqa: E402
from lab.description import load_robot  # noqa: E402
from lab.learn import STOP_MESSAGES, TrainLog, stop_message  # noqa: E402
from lab.rig.hardware_config import load_hardware_config  # noqa: E402
from lab.viz import plot_lm_training, plot_setup, plot_square_frames, plot_trajectory_placement  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
#: The shipped robots driven by cables on spools, which the setup drawing shows (not the pneumatic arm).
ROBOTS = [p for p in sorted((ROOT / "lab" / "robots").glob("*.toml")) if "[[cables]]" in p.read_text()]
NOTEBOOK_PX = 1000  # the width (px) JupyterLab shows a figure at


def _data_box(patch) -> np.ndarray:
    """[[x0, y0], [x1, y1]] of a patch in data coordinates."""
    return patch.get_path().transformed(patch.get_patch_transform()).get_extents().get_points()


def _overlap(a: np.ndarray, b: np.ndarray, tol: float = 1e-6) -> bool:
    """Whether two boxes (as :func:`_data_box`) share more than an edge."""
    inside = np.minimum(a[1], b[1]) - np.maximum(a[0], b[0])
    return bool(np.all(inside > tol))


@pytest.mark.parametrize("path", ROBOTS, ids=[p.stem for p in ROBOTS])
def test_figure1_labels_inside_and_spools_apart(path):
    robot = load_robot(path)
    markers = None
    if robot.name == "three-cable":
        markers = load_hardware_config(ROOT / "lab" / "rigs" / "hardware-example.toml", robot).natnet.base_positions_W_m
    fig, (ax_side, ax_top, ax_face) = plot_setup(robot, markers)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    face = ax_face.get_window_extent(renderer)
    labels = [t for t in ax_face.texts if t.get_text()]
    assert sorted(t.get_text() for t in labels) == sorted(c.name for c in robot.cables)
    for t in labels:  # each cable's name inside the cross-section's frame ("lower-right" ran over it)
        box = t.get_window_extent(renderer)
        assert face.x0 <= box.x0 and box.x1 <= face.x1 and face.y0 <= box.y0 and box.y1 <= face.y1, t.get_text()
    boxes = [t.get_window_extent(renderer) for t in labels]
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1 :])
    # top view: spools and motors one per cable, no two overlapping (the spools' discs did)
    top = [p for p in ax_top.patches if p.get_gid() in ("spool", "motor")]
    assert len(top) == 2 * robot.n_cables
    boxes = [_data_box(p) for p in top]
    assert not any(_overlap(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1 :])
    # side view: discs apart, or exactly behind one another (same x and z: lower-left and -right)
    side = [_data_box(p) for p in ax_side.patches if p.get_gid() == "spool"]
    assert len(side) == robot.n_cables
    for i, a in enumerate(side):
        assert all(np.allclose(a, b) or not _overlap(a, b) for b in side[i + 1 :])
    plt.close(fig)


def test_figure2_tick_labels_legible_at_notebook_width(coarse_fem):
    targets = trajectories.builtin("square", 16)
    phase = np.linspace(0, 2 * np.pi, len(targets), endpoint=False)[:, None]
    commands = 1.2 + 0.8 * np.sin(phase + np.array([0.0, 2.1, 4.2]))
    fig = plot_square_frames(coarse_fem, targets, commands)  # the default layout: 4 frames, 2 a row
    fig.canvas.draw()
    width_in = fig.get_size_inches()[0]
    panels = [ax for ax in fig.axes if ax.name == "3d"]
    assert len(panels) == 4
    for ax in panels:
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            sizes = [t.get_fontsize() for t in axis.get_ticklabels() if t.get_text()] + [axis.label.get_fontsize()]
            px = min(sizes) / 72 * NOTEBOOK_PX / width_in  # text height at the notebook's width
            assert min(sizes) >= 9 and px >= 8, (min(sizes), px)  # it was 7 pt, 5.5 px
    plt.close(fig)


def _pixels_like(rgba: np.ndarray, color, tol: float = 0.12) -> int:
    return int((np.abs(rgba[..., :3] / 255.0 - np.asarray(to_rgb(color))).max(axis=-1) < tol).sum())


def test_trajectory_placement_side_view_shows_every_trajectory():
    shapes = {name: trajectories.builtin(name) for name in trajectories.BUILTIN}
    centre = trajectories.CENTRE_W
    angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    rng = np.random.default_rng(4)
    p_data = centre + rng.normal(0, [0.01, 0.02, 0.04], (200, 3))
    fig, (ax_front, ax_side) = plot_trajectory_placement(shapes, centre, angles, np.full(12, 0.05), p_data)
    fig.canvas.draw()
    rgba = np.asarray(fig.canvas.buffer_rgba())
    box = ax_side.get_window_extent()
    h = rgba.shape[0]
    side = rgba[int(h - box.y1) : int(h - box.y0), int(box.x0) : int(box.x1)]
    colors = dict(zip(shapes, plt.cm.tab10.colors))
    for name, c in colors.items():  # each colour shows (circle and square were hidden under rose and helix)
        assert _pixels_like(side, c) >= 40, (name, _pixels_like(side, c))
    # ... at its true place: a planar shape's strokes sit at its x, over its z range
    for line in ax_side.lines:
        name = line.get_label()
        if name in ("circle", "square", "rose"):
            x, z = (np.asarray(v, float) for v in line.get_data())
            np.testing.assert_allclose(x[np.isfinite(x)], 100 * shapes[name][0, 0])
            zs, z_cm = z[np.isfinite(z)], 100 * shapes[name][:, 2]
            assert z_cm.min() - 1e-9 <= zs.min() and zs.max() <= z_cm.max() + 1e-9
    plt.close(fig)


def test_lm_training_figure_has_integer_epoch_ticks():
    epochs = np.arange(21)  # 0..20: matplotlib's default ticks were 0, 2.5, 5, ...
    history = {
        "epoch": epochs,
        **{k: 1e-3 * 0.5**epochs for k in ("perf", "vperf", "tperf")},
        "gradient": 1e-2 * 0.6**epochs,
        "mu": np.maximum(1e-3 * 0.1**epochs, 1e-9),
    }
    log = TrainLog("lm", "min_grad", 20, 20, history, {"min_grad": 1e-6})
    fig, axes = plot_lm_training(log, 246)
    fig.canvas.draw()
    for ax in axes:
        lo, hi = ax.get_xlim()
        ticks = [t for t in ax.get_xticks() if lo <= t <= hi]
        assert len(ticks) >= 3 and all(float(t).is_integer() for t in ticks), ticks
    assert fig._suptitle.get_text() == "trainlm on 246 training samples: minimum gradient reached"
    assert "min_grad = 1e-6" in [t.get_text() for t in axes[1].get_legend().get_texts()]
    plt.close(fig)


def test_stop_messages_read_inside_a_sentence():
    for reason, text in STOP_MESSAGES.items():
        assert text == text.strip() and not text.endswith(".") and text[0].islower(), reason
        assert f"stopped: {stop_message({'stop_reason': reason})} after 3 epochs".count(".") == 0
    # a model file written before: its stored MATLAB text, full stop and all, reads the same
    assert stop_message({"stop_reason": "min_grad", "stop_message": "Minimum gradient reached."}) == (
        "minimum gradient reached"
    )
    assert stop_message({"stop_reason": "tolerance", "stop_message": "loss change below tol."}) == (
        "loss change below tol"
    )
    assert stop_message({}) == "?"
