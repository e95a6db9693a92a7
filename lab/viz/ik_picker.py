"""Pick a tip target and watch inverse kinematics move the arm there (chapter 04).

:class:`IKPicker` answers a target ``p_target_W`` (3,) m with the IK command found through
the **learned model** (:meth:`lab.control.IKSolver.for_model`) in a millisecond or two,
solving from the nearest grid seed and from the previous command and keeping the better.
It draws the FEM's equilibrium at that command (:class:`lab.viz.sliders.ArmExplorer`,
warm-started), so the gap between its tip and the target is the model error; without an
FEM the arm is a schematic arc ending at the predicted tip. The dashed path is the model's
tip while the motors move linearly from the previous command to the new one.

:meth:`IKPicker.update` is plain Python (tests call it headless); :meth:`IKPicker.widget`
wraps it in x/y/z sliders (cm) and a drop-down of trajectory points, or prints why it
cannot (no ipywidgets, or run by papermill) and shows the last static figure. In an
interactive front end the arm, the target (pink), the model's tip (blue), its path and the
trajectory's points move in this kernel's live meshcat viewer (:mod:`lab.viz.live`). The
drop-down shows "custom target" as soon as a slider moves the target off a trajectory point.
"""

from __future__ import annotations

import time

import numpy as np

from lab.control.ik import IKSolver, check_targets
from lab.errors import InputError
from lab.viz.arm import TIP_RGB
from lab.viz.live import front_end_available
from lab.viz.sliders import figure_png, fixed_width_slider, still_box
from lab.viz.style import CABLE_COLORS, TARGET_COLOR

__all__ = ["IKPicker", "front_end_available", "CUSTOM_TARGET"]

#: Colour of the model's predicted tip and its path.
PREDICTED_COLOR = "#1f3a93"
#: The drop-down's entry for a target set with the sliders (not a trajectory point).
CUSTOM_TARGET = "custom target"


def arc_W(p_tip_W, n: int = 30) -> np.ndarray:
    """Points (n, 3) m of the circular arc leaving the base (origin) along +x and ending at
    ``p_tip_W`` (3,) m: a schematic arm when no FEM is at hand."""
    p = np.asarray(p_tip_W, float)
    a, perp = p[0], np.array([0.0, p[1], p[2]])
    b = float(np.linalg.norm(perp))
    s = np.linspace(0.0, 1.0, n)[:, None]
    if b < 1e-9 * max(abs(a), 1e-12):
        return s * p
    n_W = perp / b
    R, theta = (a * a + b * b) / (2 * b), 2 * np.arctan2(b, a)
    phi = theta * s
    return R * np.sin(phi) * np.array([1.0, 0.0, 0.0]) + R * (1 - np.cos(phi)) * n_W


class IKPicker:
    """Target picker for ``robot`` through the learned ``model``.

    Parameters
    ----------
    model : forward model
        Has ``predict`` and ``predict_and_jacobian`` (metres and radians).
    robot : RobotDescription
        The robot (its limits bound the IK).
    fem : ArmFEM, optional
        Draws the arm's equilibrium at each solved command (None: a schematic arc).
    targets_W : array_like, shape (N, 3), optional
        Trajectory points (m, world frame) offered in the drop-down and drawn in pink.
    figsize : tuple of float, optional
        Size of the static figure (inches).
    """

    def __init__(self, model, robot, fem=None, *, targets_W=None, figsize=(12, 4.2)):
        self.model, self.robot, self.figsize = model, robot, figsize
        self.solver = IKSolver.for_model(model, robot)
        self.explorer = None
        if fem is not None:
            from lab.viz.sliders import ArmExplorer

            self.explorer = ArmExplorer(fem, levels=1)
        self.targets_W = None if targets_W is None else np.atleast_2d(check_targets(targets_W))
        self.u_motor = self.solver.centre.copy()  # rad: where the arm starts
        self.p_pred_W = np.asarray(model.predict(self.u_motor), float)
        self.fig = self.axes = None
        self.last: dict | None = None
        self.scene = self.sliders = self.points = None

    def update(self, p_target_W, draw: bool = True) -> dict:
        """Solve the IK for ``p_target_W`` and (if ``draw``) redraw.

        A target out of reach gives the best allowed command with ``reachable=False``; a
        non-finite target raises :class:`lab.errors.InputError`.

        Parameters
        ----------
        p_target_W : array_like, shape (3,)
            The target (m, world frame).
        draw : bool, optional
            Redraw the static figure.

        Returns
        -------
        dict
            ``p_target_W`` (3,) m, ``u_motor`` (m,) rad, ``p_pred_W`` (3,) m (the model's tip at the
            command), ``p_tip_W`` (3,) m (FEM tip, or None without FEM), ``q`` (FEM state or None),
            ``reachable``, ``residual_m`` (``|p_pred - target|``, m), ``status``, ``path_W`` (K, 3) m,
            ``ik_s`` and ``elapsed_s`` (s).
        """
        t0 = time.perf_counter()
        target = check_targets(p_target_W)
        if target.ndim != 1:
            raise InputError(f"one target (3,) m, got shape {target.shape}")
        cold = self.solver.solve(target)  # nearest grid seed
        warm = self.solver.solve(target, self.u_motor)  # from where the arm is
        res = min((cold, warm), key=lambda r: r.residual_m)
        ik_s = time.perf_counter() - t0
        s = np.linspace(0.0, 1.0, 25)[:, None]
        path = np.asarray(self.model.predict((1 - s) * self.u_motor + s * res.u_motor), float)
        out = {
            "p_target_W": target,
            "u_motor": res.u_motor,
            "p_pred_W": res.p_pred_W,
            "p_tip_W": None,
            "q": None,
            "reachable": bool(res.reachable),
            "residual_m": float(res.residual_m),
            "status": res.status,
            "path_W": path,
            "ik_s": ik_s,
        }
        if self.explorer is not None:
            arm = self.explorer.update(res.u_motor, draw=False)
            out.update(p_tip_W=arm["p_tip_W"], q=arm["q"])
        self.u_motor, self.p_pred_W = res.u_motor, res.p_pred_W
        if draw:
            self._draw(out)
        out["elapsed_s"] = time.perf_counter() - t0
        self.last = out
        return out

    # ------------------------------------------------------------------ drawing
    def _draw(self, out) -> None:
        import matplotlib.pyplot as plt

        if self.fig is None:
            self.fig = plt.figure(figsize=self.figsize, layout="constrained")
            grid = self.fig.add_gridspec(1, 3, width_ratios=(1.5, 1.1, 0.6))
            self.axes = [self.fig.add_subplot(grid[k]) for k in range(3)]
        # fixed limits (the base, every grid command's tip; and the target), so that a move shows as a move
        reach = 100 * np.vstack([np.zeros(3), self.solver.seeds[1], out["p_target_W"]])
        lo, hi = reach.min(0) - 2.0, reach.max(0) + 2.0
        for ax, (a, b), title in zip(self.axes[:2], ((0, 2), (1, 2)), ("side view (x-z)", "front view (y-z)")):
            ax.cla()
            self._draw_view(ax, out, a, b)
            ax.set_xlim(lo[a], hi[a])
            ax.set_ylim(lo[b], hi[b])
            ax.set(title=title, xlabel=f"{'xyz'[a]} [cm]", ylabel=f"{'xyz'[b]} [cm]", aspect="equal")
            ax.grid(alpha=0.3)
        self.axes[0].legend(fontsize=7, loc="lower left")
        self._draw_motors(self.axes[2], out["u_motor"])
        self.fig.suptitle(self.headline(out), fontsize=10)

    def headline(self, out) -> str:
        """One line on an :meth:`update`: the target (cm), reached or how far off.

        Parameters
        ----------
        out : dict
            What :meth:`update` returned.

        Returns
        -------
        str
            The line.
        """
        t = 100 * out["p_target_W"]
        head = f"target ({t[0]:.1f}, {t[1]:.1f}, {t[2]:.1f}) cm: "
        if out["reachable"]:
            head += "reached by the model"
        else:
            head += f"out of reach, the model's best tip is {100 * out['residual_m']:.2f} cm away"
        if out["p_tip_W"] is not None:
            head += f"; simulated robot's tip {100 * np.linalg.norm(out['p_tip_W'] - out['p_target_W']):.2f} cm off"
        return head

    def _draw_view(self, ax, out, a: int, b: int) -> None:
        if out["q"] is not None:
            from lab.viz.arm import plot_arm

            geo = plot_arm(ax, self.explorer.fem, out["q"], dims=(a, b))  # grey cables, then each motor's colour:
            for k, pts in enumerate(geo.cables_W):
                ax.plot(100 * pts[:, a], 100 * pts[:, b], color=CABLE_COLORS[k % 6], lw=2, zorder=2)
            ax.plot([], [], "o", color=TIP_RGB, label="robot's tip (FEM)")  # plot_arm drew it
        else:
            arc = 100 * arc_W(out["p_pred_W"])
            ax.plot(
                arc[:, a], arc[:, b], "-", color="0.55", lw=6, alpha=0.5, solid_capstyle="round", label="arm (sketch)"
            )
        seeds = 100 * self.solver.seeds[1]
        ax.plot(seeds[:, a], seeds[:, b], ".", color="0.8", ms=2, zorder=0, label="tips of the grid commands")
        if self.targets_W is not None:
            t = 100 * self.targets_W
            ax.plot(t[:, a], t[:, b], ".", color=TARGET_COLOR, ms=3, alpha=0.6)
        path = 100 * out["path_W"]
        ax.plot(path[:, a], path[:, b], "--", color=PREDICTED_COLOR, lw=1, label="tip path (model)")
        p = 100 * out["p_pred_W"]
        ax.plot(p[a], p[b], "o", mfc="none", mec=PREDICTED_COLOR, ms=8, mew=1.5, label="model's tip")
        t = 100 * out["p_target_W"]
        ax.plot(t[a], t[b], "x", color=TARGET_COLOR, ms=10, mew=2.5, label="target")

    def _draw_motors(self, ax, u_motor) -> None:
        ax.cla()
        names = [c.name for c in self.robot.cables]
        ax.bar(range(len(names)), u_motor, color=[CABLE_COLORS[k % 6] for k in range(len(names))])
        ax.axhline(self.robot.u_max_rad, color="0.6", ls="--", lw=0.8)
        ax.set_xticks(range(len(names)), names, rotation=30, ha="right", fontsize=8)
        ax.set_ylim(0, 1.08 * self.robot.u_max_rad)
        ax.set(title="motor commands", ylabel="u [rad]")

    # ------------------------------------------------------------------ live viewer
    def _live_scene(self, viewer):
        """Objects under ``vis["picker"]``, sent once: the arm (:class:`lab.viz.live.LiveArm`,
        with an FEM), target, model's tip, trajectory points."""
        from matplotlib.colors import to_rgb

        from lab.viz.animation import MARKER_RADIUS_M, TARGET_RGB
        from lab.viz.arm import _hex, _meshcat
        from lab.viz.live_arm import LiveArm

        g, root = _meshcat().geometry, viewer.vis["picker"]
        root.delete()
        arm = None if self.explorer is None else LiveArm(viewer.vis, self.explorer.fem, prefix="picker/arm")
        for name, rgb in (("target", TARGET_RGB), ("model_tip", to_rgb(PREDICTED_COLOR))):  # pink: lab.viz.style
            root[name].set_object(g.Sphere(MARKER_RADIUS_M), g.MeshLambertMaterial(color=_hex(rgb)))
        if self.targets_W is not None:
            pts = np.ascontiguousarray(self.targets_W.T, np.float32)
            pink = np.tile(np.float32([[1.0], [0.41], [0.71]]), pts.shape[1])  # meshcat colours points per vertex
            root["points"].set_object(g.PointsGeometry(pts, pink), g.PointsMaterial(size=0.003))
        return root, arm

    def _live_update(self, viewer, out) -> None:
        from matplotlib.colors import to_rgb

        from lab.viz.arm import _hex, _meshcat

        g, (root, arm) = _meshcat().geometry, self.scene
        viewer.focus("picker")
        if arm is not None and out["q"] is not None:
            arm.update(out["q"], out["u_motor"])
        for name, p in (("target", out["p_target_W"]), ("model_tip", out["p_pred_W"])):
            T = np.eye(4)
            T[:3, 3] = p
            root[name].set_transform(T)
        lines = {"path": (out["path_W"], PREDICTED_COLOR)}  # geometry that changes: sent anew
        if arm is None:
            lines["sketch"] = (arc_W(out["p_pred_W"]), "0.55")
        for name, (pts, color) in lines.items():
            geometry = g.PointsGeometry(np.ascontiguousarray(pts.T, np.float32))
            root[name].set_object(g.Line(geometry, g.LineBasicMaterial(color=_hex(to_rgb(color)))))

    # ------------------------------------------------------------------ widget
    def widget(self, p_start_W=None, live: bool | None = None):
        """x/y/z sliders (cm) and a drop-down of ``targets_W`` above the arm, or None when no
        front end can show widgets: then the static figure of the last update (or of
        ``p_start_W``) is shown. Widgets kept in ``self.sliders`` and ``self.points`` (the drop-down).

        Parameters
        ----------
        p_start_W : array_like, shape (3,), optional
            The first target (m; default the first trajectory point, else the model's current tip).
        live : bool, optional
            Draw the arm in this kernel's live meshcat viewer (else a matplotlib image redrawn;
            None: :func:`lab.viz.live.live_viewer_wanted`).

        Returns
        -------
        ipywidgets.VBox or None
            The widget, or None without a widget front end.
        """
        import matplotlib.pyplot as plt

        p0 = p_start_W if p_start_W is not None else (self.p_pred_W if self.targets_W is None else self.targets_W[0])
        if not front_end_available():
            print("no widget front end here (papermill, a plain Python): the static result stands in for the picker")
            if self.last is None or p_start_W is not None:
                self.update(p0)
            plt.show()
            return None
        import ipywidgets as w

        from lab.viz import live as L

        live = L.live_viewer_wanted() if live is None else live
        lo, hi = 100 * self.solver.seeds[1].min(0) - 1, 100 * self.solver.seeds[1].max(0) + 1
        sliders = [
            fixed_width_slider(f"target {'xyz'[k]} [cm]", float(np.clip(100 * p0[k], lo[k], hi[k])), lo[k], hi[k], 0.1)
            for k in range(3)
        ]
        n = 0 if self.targets_W is None else len(self.targets_W)
        options = [(CUSTOM_TARGET, -1)] + [(f"trajectory point {i}", i) for i in range(n)]
        start = [i for i in range(n) if np.allclose(self.targets_W[i], p0)][:1] or [-1]
        points = w.Dropdown(options=options, value=start[0], layout=w.Layout(width="auto"))
        status, busy = w.HTML(), [False]
        if live:
            viewer = L.live_viewer()
            self.scene = self._live_scene(viewer)
            canvas = w.HTML(viewer.iframe_html(), layout=w.Layout(width="100%"))
        else:
            canvas = w.Image(format="png")

        def solve():
            out = self.update([s.value / 100 for s in sliders], draw=not live)
            if live:
                self._live_update(viewer, out)
            else:
                canvas.value = figure_png(self.fig)
            status.value = f"{self.headline(out)}<br>IK {1e3 * out['ik_s']:.1f} ms, redraw included " + (
                f"{1e3 * out['elapsed_s']:.0f} ms; "
                + ("reached" if out["reachable"] else "<b>out of reach</b>: best allowed command shown")
            )

        def on_slider(_change):
            if busy[0]:
                return
            points.value = -1  # the target is no longer the trajectory point (on_point ignores -1)
            solve()

        def on_point(change):
            if change["new"] < 0:
                return
            busy[0] = True
            for s, v in zip(sliders, 100 * self.targets_W[change["new"]]):
                s.value = float(np.clip(v, s.min, s.max))
            busy[0] = False
            solve()

        for s in sliders:
            s.observe(on_slider, names="value")
        points.observe(on_point, names="value")
        solve()
        if self.fig is not None:
            plt.close(self.fig)  # shown through the Image widget only
        self.sliders, self.points = sliders, points
        children = [*sliders, points, status, canvas] if n else [*sliders, status, canvas]
        return still_box(children, None if live else canvas)  # (the image: where no widget shows)
