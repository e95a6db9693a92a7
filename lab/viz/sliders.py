"""An interactive arm: one slider per motor that redraws the deformed FEM arm.

:class:`ArmExplorer` answers a command ``u`` (rad) with the arm's equilibrium in about a
tenth of a second on the default mesh. It keeps the equilibria it has solved, with their
sensitivities ``dq/du``, and starts each new solve from the nearest one moved along its
sensitivity (the predictor of chapter 01, section 7): a few Newton steps instead of a
dozen. The pose drawn is the exact equilibrium, not an interpolation.

The logic (:meth:`ArmExplorer.update`) is plain Python, so tests and papermill call it
headless; :meth:`ArmExplorer.widget` wraps it in ipywidgets sliders when a front end
can show them, and otherwise (no ipywidgets, or no kernel front end) returns ``None``
after saying so, leaving the static figure in place. In an interactive front end the
sliders move the arm in this kernel's live meshcat viewer (:mod:`lab.viz.live`); under
papermill they redraw a matplotlib image instead, and the widget carries that image as its
still (:func:`lab.viz.sliders.still_box`): a saved notebook opened without a kernel, or the
site's recorded run, shows the arm the sliders drew, not the widget's text. Every slider has
the same description and track width (:data:`SLIDER_STYLE`, :data:`SLIDER_LAYOUT`),
whatever its label.
"""

from __future__ import annotations

import base64
import functools
import time

import numpy as np

from lab.errors import InputError
from lab.viz.live import widgets_available

__all__ = [
    "ArmExplorer",
    "widgets_available",
    "figure_png",
    "fixed_width_slider",
    "still_box",
    "SLIDER_STYLE",
    "SLIDER_LAYOUT",
]

#: One description width and one total width for every slider of the course's widgets, so
#: that their tracks line up ("initial" sized each description to its text: 147/108/98 px).
SLIDER_STYLE = {"description_width": "8.5em"}
SLIDER_LAYOUT = {"width": "36em"}


def fixed_width_slider(description: str, value: float, lo: float, hi: float, step: float):
    """An ``ipywidgets.FloatSlider`` with :data:`SLIDER_STYLE` and :data:`SLIDER_LAYOUT`,
    solving when let go (``continuous_update=False``)."""
    import ipywidgets as w

    return w.FloatSlider(
        value=value,
        min=lo,
        max=hi,
        step=step,
        description=description,
        continuous_update=False,
        style=dict(SLIDER_STYLE),
        layout=w.Layout(**SLIDER_LAYOUT),
    )


def figure_png(fig, dpi: int = 90) -> bytes:
    """The figure as PNG bytes, for an ``ipywidgets.Image``: a widget's value, not display
    output, so a headless kernel run (papermill, nbclient) sends no Output-widget traffic."""
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


@functools.cache
def _still_box_class():
    import ipywidgets as w

    class StillBox(w.VBox):
        """A VBox whose display carries its canvas's PNG beside the widget view."""

        def __init__(self, children, canvas=None):
            super().__init__(children)
            self.canvas = canvas

        def _repr_mimebundle_(self, **kwargs):
            data = super()._repr_mimebundle_(**kwargs)
            png = getattr(self.canvas, "value", b"")
            if png and isinstance(data, dict):
                data["image/png"] = base64.b64encode(png).decode("ascii")
            return data

    return StillBox


def still_box(children, canvas=None):
    """An ``ipywidgets.VBox`` of ``children`` that, when displayed, also carries the PNG its
    ``canvas`` holds then (the image its sliders drew last) as an ``image/png`` beside the
    widget view. A front end with a widget manager (JupyterLab) shows the widget; a page
    without one (a saved notebook opened elsewhere, the site's recorded runs) shows the image
    instead of the widget's text (its repr, ``VBox(...)``).

    Parameters
    ----------
    children : sequence of ipywidgets.Widget
        The box's widgets.
    canvas : ipywidgets.Image, optional
        The widget whose PNG ``value`` is the still (None, or an empty value: no still, as
        for the live viewer's iframe).

    Returns
    -------
    ipywidgets.VBox
        The box.
    """
    return _still_box_class()(list(children), canvas=canvas)


class ArmExplorer:
    """Motor-angle sliders for ``fem``.

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM (:class:`lab.fem.ArmFEM`).
    levels : int, optional
        The equilibria solved up front, on a ``levels``-per-motor grid of safe commands over
        [0, u_max] (more levels: a longer start, faster first moves).
    figsize : tuple of float, optional
        Size of the static figure (inches).
    prefix : str, optional
        The arm's name in the live viewer.
    """

    def __init__(self, fem, levels: int = 2, figsize=(11, 4.2), prefix: str = "arm"):
        from lab.fem import solve_static

        self.fem, self.robot = fem, fem.robot
        self.figsize, self.prefix = figsize, prefix  # prefix: the arm's name in the live viewer
        self.scene = self.sliders = None
        self.u_cache: list[np.ndarray] = []
        self.q_cache: list[np.ndarray] = []
        self.dq_du_cache: list[np.ndarray] = []
        self.fig = self.axes = None
        self.last: dict | None = None
        grid = np.linspace(0.0, self.robot.u_max_rad, max(1, levels))
        for u in np.array(np.meshgrid(*[grid] * self.robot.n_inputs, indexing="ij")).reshape(self.robot.n_inputs, -1).T:
            if self._safe(u):
                sol = solve_static(fem, u, q0=self._start(u), sensitivity=True)
                self._keep(u, sol)

    def _safe(self, u) -> bool:
        try:
            self.robot.check_command(u)
        except InputError:
            return False
        return True

    def _keep(self, u, sol) -> None:
        self.u_cache.append(np.array(u, float))
        self.q_cache.append(sol.q)
        self.dq_du_cache.append(sol.dq_du)

    def _start(self, u) -> np.ndarray | None:
        """The nearest kept equilibrium moved along its sensitivity to ``u``, or None."""
        if not self.u_cache:
            return None
        k = int(np.argmin(np.linalg.norm(np.array(self.u_cache) - u, axis=1)))
        return self.q_cache[k] + self.dq_du_cache[k] @ (u - self.u_cache[k])

    def update(self, u_motor, draw: bool = True) -> dict:
        """Solve the arm at ``u_motor`` and (if ``draw``) redraw it.

        An unsafe command (outside the robot's safety limits) is not solved: ``safe`` is False,
        the arm stays where it was and the title says why. InputError for a wrong number of angles.

        Parameters
        ----------
        u_motor : array_like, shape (n_cables,)
            Motor commands (rad).
        draw : bool, optional
            Redraw the static figure.

        Returns
        -------
        dict
            ``u_motor`` (n_cables,) rad, ``safe``, ``p_tip_W`` (3,) m or None, ``q`` (n_free,) m or
            None, ``iterations`` (Newton steps), ``elapsed_s`` (s).
        """
        from lab.fem import solve_static

        t0 = time.perf_counter()
        u = np.asarray(u_motor, float).reshape(-1)
        if u.shape != (self.robot.n_inputs,):
            raise InputError(f"u_motor needs {self.robot.n_inputs} motor angles (rad), got {u.shape[0]}")
        out = {"u_motor": u, "safe": self._safe(u), "p_tip_W": None, "q": None, "iterations": 0}
        if out["safe"]:
            sol = solve_static(self.fem, u, q0=self._start(u), sensitivity=True)
            self._keep(u, sol)
            out.update(q=sol.q, p_tip_W=sol.p_tip_W, iterations=sol.iterations)
        if draw:
            self._draw(out)
        out["elapsed_s"] = time.perf_counter() - t0
        self.last = out
        return out

    def _draw(self, out) -> None:
        import matplotlib.pyplot as plt

        from lab.viz.arm import plot_arm

        if self.fig is None:
            self.fig, self.axes = plt.subplots(1, 2, figsize=self.figsize, layout="constrained")
        if out["safe"]:
            for ax, dims, title in zip(self.axes, ((0, 2), (1, 2)), ("side view (x-z)", "front view (y-z)")):
                ax.cla()
                plot_arm(ax, self.fem, out["q"], out["u_motor"], dims=dims)
                # fixed limits (the arm's reach), so that a move shows as a move
                L = 100 * self.robot.length_m
                ax.set_xlim(*((-0.1 * L, 1.1 * L) if dims[0] == 0 else (-0.8 * L, 0.8 * L)))
                ax.set_ylim(-0.8 * L, 0.8 * L)
                ax.set_title(title)
        self.fig.suptitle(self.headline(out), fontsize=10)

    def headline(self, out) -> str:
        """One line on an :meth:`update`: the command and where the tip went (cm).

        Parameters
        ----------
        out : dict
            What :meth:`update` returned.

        Returns
        -------
        str
            The line.
        """
        if out["safe"]:
            p = 100 * out["p_tip_W"]
            head = f"tip at ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) cm"
        else:
            head = "unsafe command: outside the robot's safety limits, not applied"
        angles = ", ".join(f"{c.name} {v:.2f}" for c, v in zip(self.robot.cables, out["u_motor"]))
        return f"u = [{angles}] rad: {head}"

    def widget(self, step_rad: float = 0.05, live: bool | None = None):
        """ipywidgets sliders (one per motor) above the arm, or None (with a printed reason)
        when no front end can show widgets. The sliders stay in ``self.sliders``.

        Parameters
        ----------
        step_rad : float, optional
            The sliders' step (rad).
        live : bool, optional
            The arm is this kernel's live meshcat viewer, moved on every release of a slider;
            otherwise a matplotlib image redrawn (None: :func:`lab.viz.live.live_viewer_wanted`).

        Returns
        -------
        ipywidgets.VBox or None
            The sliders, status line and arm (:func:`lab.viz.sliders.still_box`: shown as the
            arm's image where no widget can be), or None without a widget front end.
        """
        if not widgets_available():
            print("no widget front end here (papermill, a plain Python): the static figures stand in for the sliders")
            return None
        import ipywidgets as w
        import matplotlib.pyplot as plt

        from lab.viz import live as L
        from lab.viz.live_arm import LiveArm

        live = L.live_viewer_wanted() if live is None else live
        u_max = self.robot.u_max_rad
        # The sliders start at the last safe command solved (:meth:`update`), which the first
        # view shows: the arm and the numbers under it agree from the start.
        start = self.last["u_motor"] if self.last is not None and self.last["safe"] else np.zeros(self.robot.n_cables)
        sliders = [
            fixed_width_slider(f"{c.name} [rad]", float(v), 0.0, u_max, step_rad)
            for c, v in zip(self.robot.cables, np.clip(start, 0.0, u_max))
        ]
        status = w.HTML()
        if live:
            viewer = L.live_viewer()
            self.scene = LiveArm(viewer.vis, self.fem, prefix=self.prefix)
            canvas = w.HTML(viewer.iframe_html(), layout=w.Layout(width="100%"))
        else:
            canvas = w.Image(format="png")

        def on_change(_change=None):
            out = self.update([s.value for s in sliders], draw=not live)
            if not live:
                canvas.value = figure_png(self.fig)
            elif out["safe"]:
                viewer.focus(self.prefix)
                self.scene.update(out["q"], out["u_motor"])
            status.value = (
                f"{self.headline(out)}; solved in {1e3 * out['elapsed_s']:.0f} ms ({out['iterations']} Newton steps)"
                if out["safe"]
                else f"<b>{self.headline(out)}</b>"
            )

        for s in sliders:
            s.observe(on_change, names="value")
        on_change()
        if self.fig is not None:
            plt.close(self.fig)  # shown through the Image widget only
        self.sliders = sliders
        return still_box([*sliders, status, canvas], None if live else canvas)
