"""Calibrated physics: identify the as-built parameters theta of the FEM from N real samples.

theta is :mod:`lab.fem.solve.parameters`' vector of the fitted groups (``softness``: log
softness; ``gradient``: stiffness gradient (y, z); ``eyelets``: eyelet shifts (m); ``slack``:
slack per angle-controlled cable (m); ``density``: the factor on the density; default the
first four, or the first three for a robot without angle-controlled cables). The data are
every observed marker of each sample, tip first, stacked (x, y, z) per marker: y_i (3K,).
:func:`calibrate` minimises the whitened misfit plus a prior towards the nominal description, theta0:

    C(theta) = sum_i |y(u_i; theta) - y_i|^2 / noise^2 + sum_j ((theta_j - theta0_j) / s_j)^2

by Levenberg-Marquardt (:mod:`lab.transfer.levenberg`) with ``J = dy/dtheta`` from the
exact-Hessian sensitivities. The prior (:data:`DEFAULT_PRIOR_STD`) keeps the problem well
posed with as few as 5 samples;
``noise`` (default 0.5 mm per coordinate) weighs the data against it. Warm starts make most
solves one or two Newton steps. The uncertainty is the Gauss-Newton (Laplace) covariance at
the optimum. Whether the model explains the data at all is a chi-square test of the residual
against ``noise`` (:func:`lab.transfer.model_check`): a correct model leaves E[RSS] = (3NK - p_eff) noise^2;
above the 99.9 % quantile of chi2(3NK - p_eff) the model is flagged, and the reported
covariance is inflated by the reduced chi-square (Birge ratio) whenever that exceeds 1.

The prior, the warm starts, the covariance and the test in full: docs/design/transfer.md.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError
from lab.fem.solve.parameter_layout import ParameterLayout, parse_groups
from lab.fem.solve.parameters import ParametrisedFEM
from lab.transfer.discrepancy import model_check
from lab.transfer.levenberg import ALGORITHMS, minimise
from lab.transfer.prior import DEFAULT_PRIOR_STD, default_groups, prior_std
from lab.transfer.samples import Samples, first_pass

__all__ = ["DEFAULT_PRIOR_STD", "CalibrationResult", "calibrate", "default_groups", "prior_std"]


@dataclass
class CalibrationResult:
    """What :func:`calibrate` found. ``theta`` (p,) in the units of ``layout``; ``covariance``
    (p, p) the reported one: ``covariance_raw`` (the Laplace covariance at the declared
    ``noise_m``) inflated by the Birge ratio when the reduced chi-square exceeds 1
    (:func:`lab.transfer.model_check`); ``residuals_m`` (N, 3K) the markers' misfit at ``theta`` in m;
    ``p_eff`` the parameters the data determine (trace of the hat matrix).

    Attributes
    ----------
    layout : ParameterLayout
        Names, units and blocks of theta (:mod:`lab.fem.solve.parameters`).
    theta, theta_nominal : numpy.ndarray
        Identified and nominal parameters, shape (p,).
    covariance : numpy.ndarray
        The reported covariance, shape (p, p).
    prior_std : numpy.ndarray
        Prior standard deviations, shape (p,).
    noise_m, sigma_m : float
        Declared noise and the noise the residuals imply, m per coordinate.
    residuals_m : numpy.ndarray
        Misfit x - y of the observed markers at ``theta``, shape (N, 3K), m.
    rms_nominal_m : float
        RMS misfit of the nominal description per marker, m.
    iterations, n_solves : int
        Levenberg-Marquardt iterations and FEM solves.
    converged : bool
        Whether the last step moved every parameter less than ``tol`` prior std.
    wall_s : float
        Wall time of the fit, s.
    n_rings, n_axial : int
        The mesh the parameters were identified on.
    history : list of dict
        One entry per iteration (``rms_m``, ``cost``, ...).
    covariance_raw : numpy.ndarray or None
        The Laplace covariance at ``noise_m``, shape (p, p).
    p_eff : float or None
        Parameters the data determine.
    markers : tuple of str
        The observed markers, in the data's order (the tip first).
    n_trials, n_rejected : int
        Levenberg-Marquardt trial steps (each re-solves the samples) and those rejected.
    n_factorisations : int
        Hessian factorisations, the solves' and the sensitivities'.
    algorithm : str
        The loop that ran (``ALGORITHMS`` of :mod:`lab.transfer.levenberg`).
    """

    layout: ParameterLayout
    theta: np.ndarray
    theta_nominal: np.ndarray
    covariance: np.ndarray
    prior_std: np.ndarray
    noise_m: float
    sigma_m: float
    residuals_m: np.ndarray
    rms_nominal_m: float
    iterations: int
    converged: bool
    n_solves: int
    wall_s: float
    n_rings: int
    n_axial: int
    history: list = field(default_factory=list, repr=False)
    covariance_raw: np.ndarray | None = None
    p_eff: float | None = None
    markers: tuple = ("tip",)
    n_trials: int = 0
    n_rejected: int = 0
    n_factorisations: int = 0
    algorithm: str = "fast"

    @property
    def std(self) -> np.ndarray:
        """One standard deviation of each parameter (p,): the reported one (inflated when the
        model does not explain the data, see :func:`lab.transfer.model_check`)."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def std_raw(self) -> np.ndarray:
        """One standard deviation (p,) at the declared noise, not inflated."""
        return np.sqrt(np.diag(self.covariance if self.covariance_raw is None else self.covariance_raw))

    @property
    def check(self) -> dict:
        """:func:`lab.transfer.model_check` of this fit (the chi-square test, JSON-able)."""
        return model_check(self.residuals_m, self.noise_m, self.layout.size, self.p_eff)

    @property
    def rms_m(self) -> float:
        """RMS misfit |x - y| over the samples and markers at ``theta``, in m."""
        return _rms(self.residuals_m)

    @property
    def values(self) -> dict:
        """theta unpacked (:meth:`~lab.fem.solve.parameter_layout.ParameterLayout.unpack`)."""
        return self.layout.unpack(self.theta)

    def summary(self) -> dict:
        """A JSON-able summary: each parameter's value, std (the reported one) and nominal,
        the fit, and the chi-square test of the residual against the noise
        (``model_discrepancy``, ``discrepancy``, ``std_reported``, ``std_raw``,
        ``std_inflated``: :func:`lab.transfer.model_check`).

        Returns
        -------
        dict
            JSON-able: ``parameters`` (name -> value, std, nominal, unit), ``rms_m``,
            ``noise_m`` (m), ``iterations``, ``wall_s`` (s), ``mesh``, the test, ...
        """
        check = self.check
        return {
            "parameters": {
                n: {"value": float(v), "std": float(s), "nominal": float(v0), "unit": unit}
                for n, v, s, v0, unit in zip(
                    self.layout.names, self.theta, self.std, self.theta_nominal, self.layout.units
                )
            },
            "softness": self.values["softness"],
            "n_samples": len(self.residuals_m),
            "rms_nominal_m": self.rms_nominal_m,
            "rms_m": self.rms_m,
            "noise_m": self.noise_m,
            "sigma_m": self.sigma_m,
            "iterations": self.iterations,
            "converged": self.converged,
            "n_solves": self.n_solves,
            "wall_s": self.wall_s,
            "mesh": {"n_rings": self.n_rings, "n_axial": self.n_axial},
            "eyelet_shift_axes": self.layout.axes,
            "fit_groups": list(self.layout.groups),
            "markers": list(self.markers),
            "model_discrepancy": check["model_discrepancy"],
            "discrepancy": check,
            "std_reported": "inflated" if check["std_inflation"] > 1 else "raw",
            "std_raw": dict(zip(self.layout.names, map(float, self.std_raw))),
            "std_inflated": dict(zip(self.layout.names, map(float, self.std))),
        }


def _rms(residuals: np.ndarray) -> float:
    """RMS 3-D misfit per observed point of residuals (N, 3K), m."""
    r = np.asarray(residuals)
    return float(np.sqrt(np.mean(np.sum(r.reshape(-1, 3) ** 2, axis=1))))


def _check_data(robot: RobotDescription, u, y, markers) -> tuple[np.ndarray, np.ndarray]:
    u, y = np.asarray(u, float), np.asarray(y, float)
    if u.ndim != 2 or u.shape[1] != robot.n_inputs or len(u) == 0:
        raise InputError(f"motor angles must be (N, {robot.n_inputs}) for {robot.name}, got shape {u.shape}")
    if y.shape != (len(u), 3 * len(markers)):
        what = "tip positions" if len(markers) == 1 else f"marker positions ({', '.join(markers)})"
        raise InputError(f"{what} must be ({len(u)}, {3 * len(markers)}), got shape {y.shape}")
    unknown = [k for k in markers if k not in robot.marker_names]
    if unknown:
        raise InputError(f"marker {unknown[0]!r} is not one of {robot.name}'s markers {list(robot.marker_names)}")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
        raise InputError("motor angles and tip positions must be finite")
    bad = np.flatnonzero(~robot.is_safe(u))
    if len(bad):
        raise InputError(
            f"sample {bad[0]} (of {len(bad)} such) has motor angles {u[bad[0]].tolist()} rad outside "
            f"{robot.name}'s allowed commands (range or safety rule)"
        )
    return u, y


#: How far a marker may be from where the nominal FEM puts it, in (length + largest radius) of
#: the body (both lie within the body's reach): positions in cm or mm read as metres are far beyond.
PLAUSIBLE_REACH = 2.0


def _check_reach(robot: RobotDescription, y: np.ndarray, nominal: np.ndarray, markers) -> None:
    """Refuse marker positions ``y`` (N, 3K) m that lie farther from the nominal FEM's ``nominal``
    (N, 3K) m than any body of ``robot``'s size reaches: a unit (or frame) mistake."""
    size = robot.length_m + robot.radius_m
    dist = np.linalg.norm((y - nominal).reshape(len(y), -1, 3), axis=2)  # (N, K), m
    i, k = np.unravel_index(int(np.argmax(dist)), dist.shape)
    if dist[i, k] <= PLAUSIBLE_REACH * size:
        return
    names = ["x", "y", "z"] + [f"{name}_{a}" for name in list(markers)[1:] for a in "xyz"]
    column = names[3 * k + int(np.argmax(np.abs(y[i, 3 * k : 3 * k + 3] - nominal[i, 3 * k : 3 * k + 3])))]
    misfit = {u: float(np.median(np.linalg.norm(f * y - nominal, axis=1))) for u, f in (("cm", 1e-2), ("mm", 1e-3))}
    unit = min(misfit, key=misfit.get)
    raise InputError(
        f"column {column!r}: sample {i} puts the {markers[k]} {dist[i, k]:.4g} m from where the nominal FEM of "
        f"{robot.name} puts it, whose body is {robot.length_m:.3g} m long (no marker is plausibly more than "
        f"{PLAUSIBLE_REACH * size:.3g} m away); the positions must be in metres, in frame W (read as {unit}, they "
        f"would lie {misfit[unit]:.3g} m from the nominal FEM's, median)"
    )


def calibrate(
    robot: RobotDescription,
    u_real,
    y_real,
    *,
    n_rings: int | None = None,
    n_axial: int | None = None,
    axes: str = "yz",
    prior=None,
    noise_m: float = 5e-4,
    max_iter: int = 30,
    tol: float = 1e-3,
    log=None,
    groups=None,
    markers=None,
    algorithm: str | None = None,
) -> CalibrationResult:
    """Identify theta of ``robot``'s FEM from real samples: inputs ``u_real`` (N, m) (rad or
    N per cable) and marker positions ``y_real`` (N, 3K) m (frame W). Mesh: ``n_rings``/``n_axial``, else
    the description's. ``axes``: eyelet-shift components ("yz" or "xyz"). ``prior``: prior
    std (see :func:`prior_std`). Converged when no parameter moves more than ``tol`` prior
    std in a step. ``log``: called with a progress line per iteration.


    Parameters
    ----------
    robot : RobotDescription
        The nominal description (the prior mean).
    u_real : array_like
        Inputs, shape (N, m): motor angles (rad) and tensions (N), each in its cable's unit.
    y_real : array_like
        Observed positions, shape (N, 3K), m, frame W: (x, y, z) of each of ``markers``.
    n_rings, n_axial : int, optional
        The mesh (default: the description's).
    axes : str
        Eyelet-shift components, ``"yz"`` or ``"xyz"``.
    prior : array_like or dict, optional
        Prior standard deviations (:func:`prior_std`).
    noise_m : float
        Declared noise of the tip positions, m per coordinate.
    max_iter : int
        Most Levenberg-Marquardt iterations.
    tol : float
        Convergence: largest step, in prior standard deviations.
    log : callable, optional
        Called with a progress line (str) per iteration.
    groups : str or sequence of str, optional
        The fitted groups (:func:`lab.fem.solve.parameter_layout.parse_groups`); default
        :func:`default_groups`.
    markers : sequence of str, optional
        The markers the columns of ``y_real`` hold, in order (names of
        ``robot.marker_names``); default all of them (K = 1, the tip, for today's robots).
    algorithm : str, optional
        The Levenberg-Marquardt loop (``ALGORITHMS`` of :mod:`lab.transfer.levenberg`):
        ``"fast"`` (default) or ``"marquardt"``, the loop before it, kept as the reference.

    Returns
    -------
    CalibrationResult
        The identified theta, its covariance and the fit.

    Raises
    ------
    InputError
        For bad data.
    LabRuntimeError
        If even the nominal FEM has no equilibrium for a sample.
    """
    t0 = time.perf_counter()
    groups = default_groups(robot) if groups is None else parse_groups(groups)
    markers = tuple(robot.marker_names if markers is None else markers)
    u, y = _check_data(robot, u_real, y_real, markers)
    if not (np.isfinite(noise_m) and noise_m > 0):
        raise InputError(f"noise must be a positive length in m, got {noise_m}")
    n_rings = robot.n_rings if n_rings is None else int(n_rings)
    n_axial = robot.n_axial if n_axial is None else int(n_axial)
    pf = ParametrisedFEM(robot, n_rings=n_rings, n_axial=n_axial, axes=axes, groups=groups)
    lay, theta0 = pf.layout, pf.nominal
    s = prior_std(lay, prior)
    algorithm = ALGORITHMS[0] if algorithm is None else algorithm
    if algorithm not in ALGORITHMS:
        raise InputError(f"algorithm must be one of {list(ALGORITHMS)}, got {algorithm!r}")
    samples = Samples(pf, u, _marker_indices(pf.fem(theta0), markers), reuse=algorithm == "fast")
    if algorithm == "marquardt":  # the reference, as it was
        q, tips, (dq, J) = samples.first(theta0)
    else:  # the same pass, not repeated for another robot of the same description and commands
        key = (robot.sha256, n_rings, n_axial, axes, tuple(groups), markers)
        q, tips, (dq, J) = first_pass(samples, theta0, key)
    _check_reach(robot, y, tips, markers)
    rms0 = _rms(tips - y)
    if log:
        log(f"nominal: RMS {_what(markers)} misfit {1e3 * rms0:.3f} mm over {len(u)} samples")
    run = minimise(samples, y, theta0, s, noise_m, (q, tips, dq, J), max_iter=max_iter, tol=tol, log=log,
                   what=_what(markers), algorithm=algorithm)  # fmt: skip
    theta, tips, J = run.theta, run.tips, run.J
    cov_raw, cov, sigma, p_eff = _covariance(J.reshape(-1, lay.size), tips - y, s, noise_m)
    return CalibrationResult(
        layout=lay,
        theta=theta,
        theta_nominal=theta0,
        covariance=cov,
        covariance_raw=cov_raw,
        p_eff=p_eff,
        prior_std=s,
        noise_m=float(noise_m),
        sigma_m=sigma,
        residuals_m=tips - y,
        rms_nominal_m=rms0,
        iterations=run.iterations,
        converged=run.converged,
        n_solves=samples.n_solves,
        wall_s=time.perf_counter() - t0,
        n_rings=n_rings,
        n_axial=n_axial,
        history=run.history,
        markers=markers,
        n_trials=run.trials,
        n_rejected=run.rejected,
        n_factorisations=samples.n_factorisations,
        algorithm=algorithm,
    )


def _what(markers) -> str:
    return "tip" if len(markers) == 1 else "marker"


def _marker_indices(fem, markers) -> list[int]:
    """Where each observed marker sits among the FEM's (``fem.marker_names``)."""
    missing = [k for k in markers if k not in fem.marker_names]
    if missing:
        raise InputError(f"the FEM observes no marker {missing[0]!r} (it observes {list(fem.marker_names)})")
    return [fem.marker_names.index(k) for k in markers]


def _covariance(J: np.ndarray, residuals: np.ndarray, s: np.ndarray, noise_m: float):
    """Laplace covariances (p, p) at the declared noise (raw) and at ``max(noise_m, sigma)``
    (inflated by the Birge ratio), sigma (m, the noise the residuals imply) and p_eff."""
    prior = np.diag(1 / s**2)
    M = J.T @ J / noise_m**2
    p_eff = float(np.trace(np.linalg.solve(M + prior, M)))
    sigma = float(np.sqrt(np.sum(residuals**2) / max(J.shape[0] - p_eff, 1.0)))
    inflated = J.T @ J / max(sigma, noise_m) ** 2 + prior
    return np.linalg.inv(M + prior), np.linalg.inv(inflated), sigma, p_eff
