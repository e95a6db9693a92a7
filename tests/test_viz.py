"""Tests of lab.viz: drawable geometry, matplotlib figures, and the meshcat scene
rendered in real headless Chromium (WebGL through SwiftShader, no network)."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from PIL import Image

from lab.description import load_robot
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static
from lab.viz import arm as viz

matplotlib.use("Agg")
CHROMIUM = Path("/usr/bin/chromium")
U_BENT = np.array([3.0, 0.0, 0.0])  # top cable at u_max: arm bends up, tip ~(16, 0, 9) cm


@pytest.fixture(scope="module")
def fem():
    return ArmFEM(load_robot("three-cable"))


@pytest.fixture(scope="module")
def bent_q(fem):
    return solve_static(fem, U_BENT).q


def test_arm_geometry_matches_mesh_and_cables(fem, bent_q):
    rest = viz.arm_geometry(fem)
    np.testing.assert_array_equal(rest.nodes_W, fem.X_W)
    np.testing.assert_array_equal(rest.triangles, fem.mesh.surface_triangles())
    # Every surface triangle is a face of exactly one tet, and all surface nodes of
    # a closed cylinder are on it: base and tip faces plus the mantle.
    assert rest.triangles.max() < fem.mesh.n_nodes
    r = np.hypot(fem.X_W[:, 1], fem.X_W[:, 2])
    on_surface = (
        (r > fem.robot.radius_m - 1e-9) | np.isclose(fem.X_W[:, 0], 0) | np.isclose(fem.X_W[:, 0], fem.robot.length_m)
    )
    np.testing.assert_array_equal(np.unique(rest.triangles), np.flatnonzero(on_surface))

    geo = viz.arm_geometry(fem, bent_q)
    np.testing.assert_allclose(geo.nodes_W, fem.to_nodes(bent_q))
    np.testing.assert_array_equal(geo.triangles, rest.triangles)
    np.testing.assert_allclose(geo.tip_W, fem.tip(fem.to_nodes(bent_q)))
    assert len(geo.cables_W) == fem.robot.n_cables
    for cable, pts, pts0 in zip(fem.robot.cables, geo.cables_W, rest.cables_W):
        assert pts.shape == (len(cable.via_points_m) + 1, 3)
        np.testing.assert_allclose(pts[0], cable.anchor_m)  # starts at the anchor
        np.testing.assert_allclose(pts0[1:], cable.via_points_m, atol=1e-12)  # rest: the eyelets
    assert geo.tip_W[2] > 0.05  # bent upwards


def test_cable_colors():
    c = viz.cable_colors(3, [0.0, 1.5, 3.0], u_max=3.0)
    assert c.shape == (3, 3) and np.all((0 <= c) & (c <= 1))
    assert len({tuple(x) for x in c}) == 3
    np.testing.assert_allclose(viz.cable_colors(2), [viz.CABLE_RGB] * 2)


def test_meshcat_scene_update_and_stop(fem, bent_q):
    with viz.meshcat_visualizer() as vis:
        server = vis.window.server_proc
        viz.meshcat_scene(fem, None, vis)
        rest_html = viz.static_html(vis)
        geo = viz.update_scene(vis, fem, bent_q, U_BENT)
        bent_html = viz.static_html(vis)
        iframe = viz.notebook_html(vis, height_px=300)
    assert server.poll() is not None, "meshcat server still running after the context"
    np.testing.assert_allclose(geo.tip_W, fem.tip(fem.to_nodes(bent_q)))
    assert rest_html.lstrip().startswith("<!DOCTYPE html>") and "MeshCat.Viewer" in rest_html
    # Same commands (camera, 2 background colours, grid, axes, foam, 3 cables, tip
    # object and transform), new contents.
    assert rest_html.count('fetch("data:') == bent_html.count('fetch("data:') == 11
    assert rest_html != bent_html
    assert iframe.count("<iframe srcdoc=") == 1 and "height: 300px" in iframe

    with pytest.raises(RuntimeError, match="boom"):  # stopped on errors too
        with viz.meshcat_visualizer() as vis:
            server = vis.window.server_proc
            raise RuntimeError("boom")
    assert server.poll() is not None


def _non_background_fraction(png: Path, background=(255, 255, 255), tol=30) -> float:
    a = np.asarray(Image.open(png).convert("RGB")).astype(int)
    return float(np.mean(np.abs(a - np.array(background)).sum(-1) > tol))


def test_plot_arm_views_draws(fem, bent_q, tmp_path):
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    fig, (ax3, ax_xz, ax_yz) = viz.plot_arm_views(fem, bent_q, U_BENT)
    try:
        png = tmp_path / "views.png"
        fig.savefig(png, dpi=60)  # (3-D collections get their paths when drawn)
        n_tris = len(fem.mesh.surface_triangles())
        for ax in (ax3, ax_xz, ax_yz):
            polys = [c for c in ax.collections if isinstance(c, PolyCollection)]
            assert len(polys) == 1 and len(polys[0].get_paths()) == n_tris
            assert len(ax.lines) == fem.robot.n_cables + 1  # cables + tip marker
            assert ax.get_xlabel().endswith("[cm]")
        assert len(fig.axes) == 4  # 3 views + colour bar
        # Projections in cm: the side view's tip marker is the tip in cm.
        tip = viz.arm_geometry(fem, bent_q).tip_W
        np.testing.assert_allclose(np.ravel(ax_xz.lines[-1].get_data()), 100 * tip[[0, 2]])
    finally:
        plt.close(fig)
    frac = _non_background_fraction(png)
    assert frac > 0.05, f"figure nearly blank: {frac:.3f} of pixels drawn"


# ------------------------------------------------------------------ browser
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    # WebGL in software: ANGLE on SwiftShader (no GPU, no display).
    "--use-gl=angle",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    # Nothing may go out: no background services, no DNS.
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-default-apps",
    "--disable-extensions",
    "--no-first-run",
    "--disable-quic",
    "--host-resolver-rules=MAP * ~NOTFOUND",
    "--hide-scrollbars",
    "--window-size=800,600",
    "--virtual-time-budget=10000",  # let the page's scripts run and the scene render
]


def _no_network_prefix() -> list[str]:
    """``unshare -n`` (a network namespace with no interfaces) where allowed."""
    unshare = shutil.which("unshare")
    if unshare and subprocess.run([unshare, "-n", "true"], capture_output=True).returncode == 0:
        return [unshare, "-n"]
    return []


def devtools_command() -> list[str]:
    """How a DevToolsPage starts Chromium: no network, CHROMIUM_FLAGS without the virtual
    time budget (those tests wait for the page's own state instead)."""
    flags = [f for f in CHROMIUM_FLAGS if not f.startswith("--virtual-time-budget")]
    return [*_no_network_prefix(), str(CHROMIUM), *flags]


def _screenshot(html: str, tmp_path: Path, name: str) -> np.ndarray:
    page, png = tmp_path / f"{name}.html", tmp_path / f"{name}.png"
    page.write_text(html)
    profile = tmp_path / f"profile-{name}"
    profile.mkdir()
    cmd = [
        *_no_network_prefix(),
        str(CHROMIUM),
        *CHROMIUM_FLAGS,
        f"--user-data-dir={profile}",
        f"--screenshot={png}",
        page.as_uri(),
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
    assert run.returncode == 0 and png.exists(), f"chromium failed:\n{run.stderr[-3000:]}"
    return np.asarray(Image.open(png).convert("RGB")).astype(int)[20:]  # below meshcat's GUI bar


def _pixel_counts(img: np.ndarray) -> dict:
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return {
        "drawn": int(np.sum(np.abs(img - 255).sum(-1) > 30)),  # not the white background
        "foam": int(np.sum((r - b > 60) & (g - b > 30) & (r >= g) & (r > 150))),  # warm yellow-orange
        "magenta": int(np.sum((r - g > 60) & (b - g > 60))),  # cable at u = u_max
        "cyan": int(np.sum((g - r > 60) & (b - r > 60))),  # cables at u = 0
    }


def require_chromium() -> None:
    """Skip a browser test without chromium, or fail it when LAB_REQUIRE_BROWSER is set (CI)."""
    if not CHROMIUM.exists():
        if os.environ.get("LAB_REQUIRE_BROWSER", "") not in ("", "0"):
            pytest.fail(f"{CHROMIUM} is missing and LAB_REQUIRE_BROWSER is set")
        pytest.skip(f"{CHROMIUM} is missing")


@pytest.mark.slow
@pytest.mark.browser
def test_meshcat_scene_renders_in_chromium(fem, bent_q, tmp_path):
    require_chromium()
    with viz.meshcat_visualizer() as vis:  # a bare scene: meshcat's defaults only
        blank_html = viz.static_html(vis)
    with viz.meshcat_visualizer() as vis:  # our view settings, no arm
        viz.set_view(vis)
        empty_html = viz.static_html(vis)
    with viz.meshcat_visualizer() as vis:
        viz.meshcat_scene(fem, bent_q, vis, u_motor=U_BENT)
        arm_html = viz.static_html(vis)
        server = vis.window.server_proc
    assert server.poll() is not None, "meshcat server still running after the context"

    # Self-contained: the only URLs are an XML namespace name and the default of
    # Viewer.connect(), which the static page never calls; nothing to fetch.
    urls = set(re.findall(r"(?:https?|wss?)://[^\s\"'`)]*", arm_html))
    assert urls <= {"http://www.w3.org/1999/xhtml", "ws://${location.host}"}, urls
    page_script = arm_html.split("new MeshCat.Viewer(")[-1]
    assert "connect" not in page_script and 'fetch("data:' in page_script

    blank = _pixel_counts(_screenshot(blank_html, tmp_path, "blank"))
    empty = _pixel_counts(_screenshot(empty_html, tmp_path, "empty"))
    arm = _pixel_counts(_screenshot(arm_html, tmp_path, "arm"))
    n_pixels = 580 * 800
    print(f"pixel counts: arm {arm}, empty {empty}, blank {blank}")

    # WebGL works: the bare scene shows meshcat's sky-gradient background and grid.
    assert blank["drawn"] > 0.5 * n_pixels, "WebGL did not render the default scene"
    # The arm is drawn, in foam colour, with its cables coloured by their command.
    assert arm["drawn"] > 5000 and arm["foam"] > 5000, arm
    assert arm["foam"] > 0.6 * arm["drawn"], arm
    assert arm["magenta"] > 30 and arm["cyan"] > 30, arm
    # ... and neither our view settings nor meshcat's defaults produce such pixels.
    assert empty["drawn"] < 200, empty
    assert blank["foam"] < 500 and blank["foam"] < arm["foam"] / 10, blank
