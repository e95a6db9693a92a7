"""Still images of the 3-D scenes (:mod:`lab.viz.stills`): what a page that runs no meshcat
scene shows, within the recorded runs' 200 kB per output."""

import io

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from lab.errors import InputError  # noqa: E402
from lab.fem import solve_static  # noqa: E402
from lab.viz import SceneView, animation_still, arm_still  # noqa: E402
from lab.viz.stills import STILL_BYTES, view_angles  # noqa: E402


def _image(png):
    from PIL import Image

    return Image.open(io.BytesIO(png))


def test_arm_still_is_a_small_png_from_meshcats_camera(coarse_fem):
    import matplotlib.pyplot as plt

    u = np.array([coarse_fem.robot.u_max_rad, 0.0, 0.0])
    before = plt.get_fignums()
    png = arm_still(coarse_fem, solve_static(coarse_fem, u).q, u, size_px=(400, 320))
    assert plt.get_fignums() == before  # no pyplot figure: an inline backend shows no second copy
    image = _image(png)
    assert image.format == "PNG" and image.size == (400, 320) and len(png) < 60_000
    pixels = np.asarray(image.convert("RGB")).reshape(-1, 3).astype(int)
    assert (np.abs(pixels - [255, 255, 255]).sum(axis=1) > 60).mean() > 0.02  # the arm is drawn
    elev, azim = view_angles((0.0, -1.0, 1.0))
    assert elev == pytest.approx(45.0) and azim == pytest.approx(-90.0)


def test_animation_still_plays_in_a_loop_under_its_size(coarse_fem):
    robot = coarse_fem.robot
    u_frames = np.linspace(0.0, 1.0, 10)[:, None] * np.array([robot.u_max_rad, 0.0, 0.0])
    q, q_frames = None, []
    for u in u_frames:
        q = solve_static(coarse_fem, u, q).q
        q_frames.append(q)
    tips = np.array([coarse_fem.tip(coarse_fem.to_nodes(q)) for q in q_frames])
    png = animation_still(coarse_fem, q_frames, u_frames, targets_W=tips, fps=5.0, max_frames=4)
    image = _image(png)
    assert image.format == "PNG" and getattr(image, "is_animated", False)
    # every 3rd of 10 frames (at most 4), each shown 3 / fps; the loop never ends
    assert image.n_frames == 4 and image.info["duration"] == pytest.approx(600) and image.info["loop"] == 0
    assert len(png) <= STILL_BYTES
    small = animation_still(coarse_fem, q_frames, u_frames, max_frames=10, max_bytes=len(png) // 3)
    assert _image(small).n_frames < 10 and len(small) < len(png)  # frames left out to fit
    with pytest.raises(InputError, match="targets_W has 2 rows for 10 frames"):
        animation_still(coarse_fem, q_frames, targets_W=tips[:2])


def test_scene_view_shows_the_scene_or_its_still():
    from IPython.core.formatters import DisplayFormatter

    view = SceneView("<div>the scene</div>", b"\x89PNG still", "the arm in 3-D")
    data, _ = DisplayFormatter().format(view)
    assert data["text/html"] == view.data == "<div>the scene</div>" and data["image/png"] == b"\x89PNG still"
    assert data["text/plain"].startswith("<the arm in 3-D: 0.0 MB of HTML")
