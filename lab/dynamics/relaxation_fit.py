"""Fitting the relaxation filter (:mod:`lab.dynamics.relaxation`) to what the motion capture saw.

Two fits, both by *variable projection*: the filter is linear in every equilibrium and
amplitude, so for given time constants those come from one linear least-squares solve,
and only the few time constants (and weights) are searched nonlinearly.

* :func:`fit_exponentials` -- step responses seen from the moment the motors stopped:
  ``y(t) = y_inf + sum_k a_k exp(-t / tau_k)``, one ``y_inf`` and amplitudes per response
  and axis, time constants shared by all.
* :func:`fit_stream` -- a whole recording (:class:`Stream`): readings while the motors move
  and while they hold, any number of commands, each a ramp of the equilibrium from where
  it was to the new command's (unknown) equilibrium. Commands that are the same pose
  (the capture's reset) share one equilibrium. Gives time constants *and* weights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.dynamics.relaxation import Relaxation
from lab.errors import InputError


@dataclass
class Segment:
    """One command: the equilibrium ramps from where it was to that of ``pose``.

    Attributes
    ----------
    t_command_s : float
        When the command was sent (s): the ramp starts.
    t_arrived_s : float
        When the motors arrived (s): the ramp ends at the pose's equilibrium.
    pose : str
        A label for the commanded pose; equal labels share an equilibrium.
    """

    t_command_s: float
    t_arrived_s: float
    pose: str


@dataclass
class Stream:
    """Readings of the tip while a rig was driven, and the commands that drove it.

    Attributes
    ----------
    t_s : numpy.ndarray
        Reading times (n,), s (mid-reading).
    p_tip_W : numpy.ndarray
        Tips (n, 3), m, frame W; NaN where nothing was seen.
    n_valid : numpy.ndarray
        Frames averaged per reading (n,).
    segments : list of Segment
        The commands, in time order.
    initial_pose : str
        The pose the arm rests at before the first command.
    pace : dict or None
        How the recording kept pace with the motion capture
        (:meth:`lab.capture.pace.Pace.as_dict`), when measured.
    """

    t_s: np.ndarray
    p_tip_W: np.ndarray
    n_valid: np.ndarray
    segments: list
    initial_pose: str = "initial"
    pace: dict | None = None

    def poses(self) -> list[str]:
        """The distinct poses, in order of first use.

        Returns
        -------
        list of str
            ``initial_pose`` first, then each segment's new pose.
        """
        seen = [self.initial_pose]
        for s in self.segments:
            if s.pose not in seen:
                seen.append(s.pose)
        return seen


def input_knots(stream: Stream, poses: list[str]):
    """The equilibrium as knots ``(t (n,), weights (n, n_poses))``: at time t it is ``weights
    @ equilibria``. A command that interrupts a motion starts from where that motion was."""
    col = {p: i for i, p in enumerate(poses)}
    t0 = min(stream.t_s[0], stream.segments[0].t_command_s if stream.segments else stream.t_s[0])
    first = np.zeros(len(poses))
    first[col[stream.initial_pose]] = 1.0
    tk, wk = [t0], [first]
    for s in stream.segments:
        end = np.zeros(len(poses))
        end[col[s.pose]] = 1.0
        tc = max(s.t_command_s, t0)
        while len(tk) > 1 and tk[-1] > tc:  # interrupted: cut the ramp at tc
            start = wk[-2] + (wk[-1] - wk[-2]) * (tc - tk[-2]) / (tk[-1] - tk[-2])
            tk.pop(), wk.pop()
            if tk[-1] < tc:
                tk.append(tc), wk.append(start)
        if tk[-1] < tc:
            tk.append(tc), wk.append(wk[-1].copy())
        tk.append(max(s.t_arrived_s, tc)), wk.append(end)
    return np.array(tk), np.array(wk)


def _design(relax: Relaxation, stream: Stream, tk, wk, ok):
    """Columns: the response to each pose's equilibrium, then one free offset per mode."""
    t = stream.t_s[ok]
    B = relax.response(tk, wk, t)
    free = relax.weight * np.exp(-(t[:, None] - tk[0]) / relax.tau_s)
    return np.hstack([B, free])


def _theta_to_relax(theta, n_modes):
    tau = np.exp(np.cumsum(theta[:n_modes]))  # increasing time constants: no label switching
    logits = np.concatenate([[0.0], theta[n_modes:]])
    w = np.exp(logits - logits.max())
    return Relaxation(tau, w / w.sum())


def fit_stream(stream: Stream, n_modes: int = 2, *, tau_guess_s=(0.3, 3.0)) -> tuple[Relaxation, dict]:
    """Fit ``n_modes`` relaxation modes to a recorded stream.

    Parameters
    ----------
    stream : Stream
        The readings and commands; at least ``10 * n_modes`` valid readings.
    n_modes : int
        Number of modes K.
    tau_guess_s : tuple of float
        The range (s) of the starting time constants.

    Returns
    -------
    relax : Relaxation
        The filter, with the noise per frame (m) estimated from the residuals.
    report : dict
        ``equilibria`` {pose: (3,) m, frame W}, ``rms_m`` (per reading, m), ``n_readings``.
    """
    from scipy.optimize import least_squares

    ok = np.all(np.isfinite(stream.p_tip_W), axis=1) & (stream.n_valid > 0)
    if not stream.segments or ok.sum() < 10 * n_modes:
        raise InputError(f"too little to fit {n_modes} relaxation modes: {int(ok.sum())} readings")
    poses = stream.poses()
    tk, wk = input_knots(stream, poses)
    sw = np.sqrt(stream.n_valid[ok])[:, None]
    y = stream.p_tip_W[ok]

    def solve(theta):
        relax = _theta_to_relax(theta, n_modes)
        A = _design(relax, stream, tk, wk, ok)
        coef = np.linalg.lstsq(A * sw, y * sw, rcond=None)[0]
        return relax, coef, (A @ coef - y) * sw

    guess = np.geomspace(tau_guess_s[0], tau_guess_s[-1], n_modes)
    starts = []
    for scale in (0.5, 1.0, 2.0):
        g = guess * scale
        starts.append(np.concatenate([[np.log(g[0])], np.log(g[1:] / g[:-1]), np.zeros(n_modes - 1)]))
    best = None
    for x0 in starts:
        sol = least_squares(lambda th: solve(th)[2].ravel(), x0, method="lm", x_scale=1.0)
        if best is None or sol.cost < best.cost:
            best = sol
    relax, coef, res = solve(best.x)
    n_res = res.size
    sigma_frame = float(np.sqrt(np.sum(res**2) / max(n_res - coef.size - len(best.x), 1)))
    relax = Relaxation(
        relax.tau_s,
        relax.weight,
        sigma_frame,
        {"fit": "stream", "n_readings": int(ok.sum()), "n_commands": len(stream.segments), "poses": len(poses)},
    )
    report = {
        "equilibria": {p: coef[i] for i, p in enumerate(poses)},
        "rms_m": float(np.sqrt(np.mean(((res / sw) ** 2).sum(axis=1)))),
        "n_readings": int(ok.sum()),
    }
    return relax, report


def fit_exponentials(responses, n_modes: int = 2, *, tau_guess_s=(0.3, 3.0)):
    """Shared time constants of step responses: ``y = y_inf + sum_k a_k exp(-t / tau_k)``.

    Parameters
    ----------
    responses : list of (array_like, array_like)
        R pairs ``(t_s (n,), y (n, d))``, ``t`` (s) measured from when the motors stopped.
    n_modes : int
        Number of modes K.
    tau_guess_s : tuple of float
        The range (s) of the starting time constants.

    Returns
    -------
    tau_s : numpy.ndarray
        Time constants (K,), s, increasing.
    y_inf : numpy.ndarray
        Final values (R, d), units of ``y``.
    amplitudes : numpy.ndarray
        (R, K, d), units of ``y``.
    rms : float
        The residual's root mean square, units of ``y``.
    """
    from scipy.optimize import least_squares

    responses = [(np.asarray(t, float), np.atleast_2d(np.asarray(y, float).T).T) for t, y in responses]
    for t, y in responses:
        if len(t) != len(y) or len(t) < n_modes + 2:
            raise InputError(f"each response needs >= {n_modes + 2} readings and one time per reading")

    def solve(theta):
        tau = np.exp(np.cumsum(theta))
        out, res = [], []
        for t, y in responses:
            ok = np.all(np.isfinite(y), axis=1)
            A = np.hstack([np.ones((len(t), 1)), np.exp(-t[:, None] / tau)])
            coef = np.linalg.lstsq(A[ok], y[ok], rcond=None)[0]
            out.append(coef)
            res.append((A[ok] @ coef - y[ok]).ravel())
        return tau, out, np.concatenate(res)

    g = np.geomspace(tau_guess_s[0], tau_guess_s[-1], n_modes)
    best = None
    for scale in (0.5, 1.0, 2.0):
        x0 = np.concatenate([[np.log(g[0] * scale)], np.log(g[1:] / g[:-1])])
        sol = least_squares(lambda th: solve(th)[2], x0, method="lm")
        if best is None or sol.cost < best.cost:
            best = sol
    tau, coefs, res = solve(best.x)
    y_inf = np.array([c[0] for c in coefs])
    amplitudes = np.array([c[1:] for c in coefs])
    return tau, y_inf, amplitudes, float(np.sqrt(np.mean(res**2)))
