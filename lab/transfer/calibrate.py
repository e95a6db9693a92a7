"""Calibrated physics: identify the as-built parameters theta of the FEM from N real samples.

theta is :mod:`lab.fem.parameters`' vector (log softness, stiffness gradient (y, z), eyelet
shifts (m), slack per cable (m)). :func:`calibrate` minimises the whitened tip misfit plus a
prior towards the nominal description, theta0:

    C(theta) = sum_i |x_tip(u_i; theta) - y_i|^2 / noise^2 + sum_j ((theta_j - theta0_j) / s_j)^2

by Levenberg-Marquardt with ``J = dx_tip/dtheta`` from the exact-Hessian sensitivities. The
prior (:data:`DEFAULT_PRIOR_STD`) keeps the problem well posed with as few as 5 samples;
``noise`` (default 0.5 mm per coordinate) weighs the data against it. Warm starts make most
solves one or two Newton steps. The uncertainty is the Gauss-Newton (Laplace) covariance at
the optimum, with the noise estimated from the residuals.

The prior, the warm starts and the covariance in full: docs/design/transfer.md.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError
from lab.fem.parameters import ParameterLayout, ParametrisedFEM
from lab.transfer.samples import Samples

__all__ = ["DEFAULT_PRIOR_STD", "CalibrationResult", "calibrate", "prior_std"]

#: Prior standard deviations of each block of theta (the nominal is the prior mean):
#: log softness 0.4 (E x/ 1.5), gradient 0.4 per component, eyelet shift 2 mm per axis,
#: slack 3 mm -- about the half-widths of the as-built family's ranges.
DEFAULT_PRIOR_STD = {"log_softness": 0.4, "gradient": 0.4, "via_shift_m": 2e-3, "slack_m": 3e-3}


@dataclass
class CalibrationResult:
    """What :func:`calibrate` found. ``theta`` (p,) in the units of ``layout``; ``covariance``
    (p, p); ``residuals_m`` (N, 3) the tip misfit at ``theta`` in m."""

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

    @property
    def std(self) -> np.ndarray:
        """One standard deviation of each parameter (p,)."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def rms_m(self) -> float:
        """RMS tip misfit |x - y| over the samples at ``theta``, in m."""
        return float(np.sqrt(np.mean(np.sum(self.residuals_m**2, axis=1))))

    @property
    def values(self) -> dict:
        """theta unpacked: softness, gradient (2,), via_shift_m (m, 3), slack_m (m,)."""
        return self.layout.unpack(self.theta)

    def summary(self) -> dict:
        """A JSON-able summary: each parameter's value, std and nominal, and the fit."""
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
        }


def prior_std(layout: ParameterLayout, std=None) -> np.ndarray:
    """Prior standard deviations (p,): ``std`` as an array (p,), or a dict overriding blocks
    of :data:`DEFAULT_PRIOR_STD` (keys as there)."""
    if std is not None and not isinstance(std, dict):
        s = np.asarray(std, float)
        if s.shape != (layout.size,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise InputError(f"prior std must be {layout.size} positive numbers, got {s.tolist()}")
        return s
    d = {**DEFAULT_PRIOR_STD, **(std or {})}
    unknown = set(d) - set(DEFAULT_PRIOR_STD)
    if unknown or not all(np.isfinite(v) and v > 0 for v in d.values()):
        raise InputError(f"prior std: positive values for {sorted(DEFAULT_PRIOR_STD)}, got {d}")
    s = np.full(layout.size, d["via_shift_m"])
    s[0], s[1:3], s[layout.slack] = d["log_softness"], d["gradient"], d["slack_m"]
    return s


def _check_data(robot: RobotDescription, u, y) -> tuple[np.ndarray, np.ndarray]:
    u, y = np.asarray(u, float), np.asarray(y, float)
    if u.ndim != 2 or u.shape[1] != robot.n_cables or len(u) == 0:
        raise InputError(f"motor angles must be (N, {robot.n_cables}) for {robot.name}, got shape {u.shape}")
    if y.shape != (len(u), 3):
        raise InputError(f"tip positions must be ({len(u)}, 3), got shape {y.shape}")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
        raise InputError("motor angles and tip positions must be finite")
    bad = np.flatnonzero(~robot.is_safe(u))
    if len(bad):
        raise InputError(
            f"sample {bad[0]} (of {len(bad)} such) has motor angles {u[bad[0]].tolist()} rad outside "
            f"{robot.name}'s allowed commands (range or safety rule)"
        )
    return u, y


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
) -> CalibrationResult:
    """Identify theta of ``robot``'s FEM from real samples: motor angles ``u_real`` (N, m) rad
    and tip positions ``y_real`` (N, 3) m (frame W). Mesh: ``n_rings``/``n_axial``, else
    the description's. ``axes``: eyelet-shift components ("yz" or "xyz"). ``prior``: prior
    std (see :func:`prior_std`). Converged when no parameter moves more than ``tol`` prior
    std in a step. ``log``: called with a progress line per iteration.

    Raises InputError for bad data, LabRuntimeError if even the nominal FEM has no
    equilibrium for a sample."""
    t0 = time.perf_counter()
    u, y = _check_data(robot, u_real, y_real)
    if not (np.isfinite(noise_m) and noise_m > 0):
        raise InputError(f"noise must be a positive length in m, got {noise_m}")
    n_rings = robot.n_rings if n_rings is None else int(n_rings)
    n_axial = robot.n_axial if n_axial is None else int(n_axial)
    pf = ParametrisedFEM(robot, n_rings=n_rings, n_axial=n_axial, axes=axes)
    lay, theta0 = pf.layout, pf.nominal
    s = prior_std(lay, prior)
    samples = Samples(pf, u)
    q, tips, (dq, J) = samples.first(theta0)

    def cost(theta, tips):
        return float(np.sum((tips - y) ** 2) / noise_m**2 + np.sum(((theta - theta0) / s) ** 2))

    theta, c, lam, converged, it = theta0.copy(), cost(theta0, tips), 1e-3, False, 0
    rms0 = float(np.sqrt(np.mean(np.sum((tips - y) ** 2, axis=1))))
    history = [{"iteration": 0, "rms_m": rms0, "cost": c}]
    if log:
        log(f"nominal: RMS tip misfit {1e3 * rms0:.3f} mm over {len(u)} samples")
    while it < max_iter and not converged:
        it += 1
        Jd = J.reshape(-1, lay.size) / noise_m
        A = Jd.T @ Jd + np.diag(1 / s**2)
        b = Jd.T @ ((tips - y).ravel() / noise_m) + (theta - theta0) / s**2
        while True:
            step = np.linalg.solve(A + lam * np.diag(np.diag(A)), -b)
            trial = theta + step
            got = samples.solve(trial, q + dq @ step)
            if got is not None and (c_trial := cost(trial, got[1])) < c:
                break
            lam *= 4.0
            if lam > 1e10:
                break
        if lam > 1e10:  # no step decreases the cost: at the minimum to rounding
            converged = True
            break
        lam = max(lam / 3.0, 1e-9)
        theta, c, (q, tips) = trial, c_trial, got
        dq, J = samples.sensitivities(theta, q)
        converged = bool(np.max(np.abs(step) / s) < tol)
        rms = float(np.sqrt(np.mean(np.sum((tips - y) ** 2, axis=1))))
        history.append(
            {"iteration": it, "rms_m": rms, "cost": c, "max_step_over_prior_std": float(np.max(abs(step) / s))}
        )
        if log:
            log(
                f"iteration {it}: RMS tip misfit {1e3 * rms:.3f} mm, largest step {np.max(abs(step) / s):.2g} prior std"
            )
    cov, sigma = _covariance(J.reshape(-1, lay.size), tips - y, s, noise_m)
    return CalibrationResult(
        layout=lay,
        theta=theta,
        theta_nominal=theta0,
        covariance=cov,
        prior_std=s,
        noise_m=float(noise_m),
        sigma_m=sigma,
        residuals_m=tips - y,
        rms_nominal_m=rms0,
        iterations=it,
        converged=converged,
        n_solves=samples.n_solves,
        wall_s=time.perf_counter() - t0,
        n_rings=n_rings,
        n_axial=n_axial,
        history=history,
    )


def _covariance(J: np.ndarray, residuals: np.ndarray, s: np.ndarray, noise_m: float):
    """Laplace covariance (p, p) and the residual noise estimate sigma (m), module docstring."""
    prior = np.diag(1 / s**2)
    M = J.T @ J / noise_m**2
    p_eff = float(np.trace(np.linalg.solve(M + prior, M)))
    sigma = float(np.sqrt(np.sum(residuals**2) / max(J.shape[0] - p_eff, 1.0)))
    return np.linalg.inv(J.T @ J / max(sigma, 1e-12) ** 2 + prior), sigma
