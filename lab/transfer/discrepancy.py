"""Does a fitted model explain its samples? The chi-square test of the residual against the noise.

A correct model with the right declared noise leaves ``chi2 = RSS / noise^2`` distributed as
chi2(dof), ``dof = 3NK - p_eff`` (K observed markers) (``p_eff`` the parameters the data determine: with a prior,
the trace of the hat matrix). :func:`model_check` flags a fit above the
:data:`DISCREPANCY_QUANTILE` quantile as model error, and gives the Birge ratio by which
:func:`lab.transfer.calibrate` inflates the reported standard deviations. The reasoning in
full: docs/design/transfer.md.
"""

from __future__ import annotations

import numpy as np

__all__ = ["DISCREPANCY_QUANTILE", "model_check"]

#: A residual above this quantile of chi2(3N - p_eff) is model error, not noise: a correct
#: model with the right noise is flagged once in a thousand fits.
DISCREPANCY_QUANTILE = 0.999


def model_check(residuals_m, noise_m: float, p: int, p_eff: float | None = None) -> dict:
    """The chi-square test of a fit's residuals ``residuals_m`` (N, 3K) m against the declared
    noise ``noise_m`` (m per coordinate) for ``p`` parameters, ``p_eff`` of them determined by
    the data (default ``p``; with a prior, the trace of the hat matrix). A correct model
    leaves ``chi2 = RSS / noise^2 ~ chi2(dof)``, ``dof = 3NK - p_eff``: RMS 3-D residual per
    observed point ``noise sqrt(dof / NK)``. ``model_discrepancy`` when chi2 exceeds the
    :data:`DISCREPANCY_QUANTILE` quantile; ``std_inflation = max(1, sqrt(chi2 / dof))`` (the
    Birge ratio, at least 1) scales the data's part of the standard deviations. Lengths in m.

    Parameters
    ----------
    residuals_m : array_like
        Residuals of the K observed markers, shape (N, 3K), m (the tip alone: (N, 3)).
    noise_m : float
        Declared noise, m per coordinate.
    p : int
        Number of parameters.
    p_eff : float, optional
        Parameters the data determine (default ``p``).

    Returns
    -------
    dict
        JSON-able: ``model_discrepancy`` (bool), ``rms_m``, ``expected_rms_m``,
        ``threshold_rms_m`` (m), ``dof``, ``chi2``, ``p_value``, ``reduced_chi2``,
        ``std_inflation`` and the test's settings.
    """
    from scipy.stats import chi2 as chi2_dist

    r = np.asarray(residuals_m, float).reshape(-1, 3)  # one row per observed point
    n = len(r)
    p_eff = float(p if p_eff is None else p_eff)
    dof = max(3 * n - p_eff, 1.0)
    chi2 = float(np.sum(r**2) / noise_m**2)
    limit = float(chi2_dist.ppf(DISCREPANCY_QUANTILE, dof))
    return {
        "model_discrepancy": bool(chi2 > limit),
        "test": f"chi-square of the residual against the noise, flagged above the {DISCREPANCY_QUANTILE:g} quantile",
        "rms_m": float(np.sqrt(np.sum(r**2) / n)),
        "expected_rms_m": float(noise_m * np.sqrt(dof / n)),
        "threshold_rms_m": float(noise_m * np.sqrt(limit / n)),
        "noise_m": float(noise_m),
        "n_data": 3 * n,
        "p": int(p),
        "p_eff": p_eff,
        "dof": dof,
        "chi2": chi2,
        "chi2_threshold": limit,
        "quantile": DISCREPANCY_QUANTILE,
        "p_value": float(chi2_dist.sf(chi2, dof)),
        "reduced_chi2": chi2 / dof,
        "birge_ratio": float(np.sqrt(chi2 / dof)),
        "std_inflation": float(max(1.0, np.sqrt(chi2 / dof))),
    }
