"""How well a predicted spread explains held-out errors: the calibration of a model's std.

A model with a spread (a deep ensemble, :class:`lab.learn.ensemble.Ensemble`; a Gaussian
process, :class:`lab.learn.peers_gp.GPRModel`) predicts a mean and a standard deviation
(m, per coordinate) for each command. :func:`calibration` compares them with measured
values: the share of errors within one and two predicted standard deviations, against a
Gaussian's 68.27 % and 95.45 % (:data:`GAUSS_1SIGMA`, :data:`GAUSS_2SIGMA`), and the same
for the error radius of each sample (chi-distributed). Fractions below the Gaussian ones
mean an over-confident spread. The formulas: docs/design/learn.md.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError

__all__ = ["GAUSS_1SIGMA", "GAUSS_2SIGMA", "z_scores", "calibration"]

#: P(|z| <= 1) and P(|z| <= 2) for z ~ N(0, 1).
GAUSS_1SIGMA, GAUSS_2SIGMA = 0.6827, 0.9545


def z_scores(y_true, mean, std) -> np.ndarray:
    """Each error in predicted standard deviations, ``|y_true - mean| / std``.

    Parameters
    ----------
    y_true, mean, std : array_like
        Measured values, predicted means and spreads, shape (N, n_y), m.

    Returns
    -------
    numpy.ndarray
        z, shape (N, n_y); inf for an error where std = 0, 0 for none.
    """
    err = np.abs(np.asarray(y_true, float) - mean)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(std > 0, err / np.where(std > 0, std, 1.0), np.where(err > 0, np.inf, 0.0))


def calibration(y_true, mean, std) -> dict:
    """How well a predicted spread explains held-out errors. ``y_true``, ``mean``, ``std``:
    (N, n_y) m (std > 0; a zero std counts any error as outside every interval).

    Per coordinate, ``z = |y_true - mean| / std`` over all N * n_y entries:
    ``within_1sigma`` = fraction with z <= 1 and ``within_2sigma`` with z <= 2, to compare
    with the Gaussian ``gaussian_1sigma`` = 0.6827 and ``gaussian_2sigma`` = 0.9545;
    ``rms_z`` = sqrt(mean z^2) over the finite z (1 when calibrated; > 1 over-confident).
    Per sample, the normalised error radius ``d = sqrt(sum_i z_i^2)`` is chi-distributed
    with n_y degrees of freedom if the errors are independent Gaussians of the predicted
    std; ``radius_within_68`` and ``radius_within_95`` are the fractions of samples with
    d below chi(n_y)'s 0.6827 and 0.9545 quantiles (``chi_q68``, ``chi_q95``: 1.878 and
    2.833 for n_y = 3). Fractions below the Gaussian reference mean over-confidence.

    Parameters
    ----------
    y_true, mean, std : array_like
        Measured values, predicted means and spreads, shape (N, n_y), m.

    Returns
    -------
    dict
        ``n``, the fractions (0 to 1) and references named above, and ``rms_z``.
    """
    y_true, mean, std = (np.asarray(a, float) for a in (y_true, mean, std))
    if y_true.ndim != 2 or mean.shape != y_true.shape or std.shape != y_true.shape or len(y_true) == 0:
        raise InputError(
            f"y_true, mean and std must share one (N, n_y) shape, got {y_true.shape}, {mean.shape}, {std.shape}"
        )
    z = z_scores(y_true, mean, std)
    d = np.sqrt(np.sum(z * z, axis=1))
    finite = np.isfinite(z)
    n_y = y_true.shape[1]
    from scipy.stats import chi2  # here: scipy.stats costs ~0.4 s to import, and the CLI starts without it

    q68, q95 = (float(np.sqrt(chi2.ppf(p, n_y))) for p in (GAUSS_1SIGMA, GAUSS_2SIGMA))
    return {
        "n": int(len(y_true)),
        "within_1sigma": float(np.mean(z <= 1.0)),
        "within_2sigma": float(np.mean(z <= 2.0)),
        "gaussian_1sigma": GAUSS_1SIGMA,
        "gaussian_2sigma": GAUSS_2SIGMA,
        "rms_z": float(np.sqrt(np.mean(z[finite] ** 2))) if np.any(finite) else None,
        "radius_within_68": float(np.mean(d <= q68)),
        "radius_within_95": float(np.mean(d <= q95)),
        "chi_q68": q68,
        "chi_q95": q95,
    }
