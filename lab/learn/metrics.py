"""How accurate is the learned model? Error metrics and the workspace size.

Metrics, for predicted ``y_hat`` and measured ``y`` tip positions (N, 3) in metres:

* ``mse_m2`` -- MATLAB ``mse``: mean over samples *and* coordinates of the squared error (m^2);
* ``mean_distance_m`` -- mean Euclidean distance ``|y_hat_i - y_i|`` (m), the paper's
  "average Euclidean distance between the predicted and measured tip position".

**Workspace size** (for relative errors): the diagonal of the axis-aligned bounding box
of all measured tip positions of the dataset, ``|max_i y_i - min_i y_i|`` (m). The paper
does not define it; its 4.42 mm = 1.6 % implies a size of about 0.28 m.

The repeated-split and network-size studies that use them are in :mod:`lab.learn.studies`.
"""

from __future__ import annotations

import numpy as np


def mse_m2(y_hat: np.ndarray, y: np.ndarray) -> float:
    """Mean over samples and coordinates of the squared error (m^2); NaN for no samples.

    Parameters
    ----------
    y_hat, y : numpy.ndarray
        Predicted and measured positions, shape (N, 3) (or (N, n_y)), m.

    Returns
    -------
    float
        The MSE, m^2.
    """
    return float(np.mean((np.asarray(y_hat) - y) ** 2)) if len(y) else float("nan")


def mean_distance_m(y_hat: np.ndarray, y: np.ndarray) -> float:
    """Mean Euclidean distance between predicted and measured positions (m); NaN for none.

    With several markers (n_y = 3K, K > 1) the mean is over samples and markers of each
    marker's distance.

    Parameters
    ----------
    y_hat, y : numpy.ndarray
        Predicted and measured positions, shape (N, 3) (or (N, 3K) for K markers), m.

    Returns
    -------
    float
        The mean distance, m.
    """
    if not len(y):
        return float("nan")
    d = np.asarray(y_hat) - y
    if d.ndim == 2 and d.shape[1] > 3 and d.shape[1] % 3 == 0:
        return float(np.mean(np.linalg.norm(d.reshape(len(d), -1, 3), axis=2)))
    return float(np.mean(np.linalg.norm(d, axis=1)))


def error_report(model, u: np.ndarray, y: np.ndarray) -> dict:
    """{"mse_m2", "mean_distance_m", "n"} of ``model`` on (u, y); None values for an empty set.

    Parameters
    ----------
    model : object
        A forward model with ``predict``.
    u : numpy.ndarray
        Commands, shape (N, n_u), rad.
    y : numpy.ndarray
        Measured tips, shape (N, 3), m.

    Returns
    -------
    dict
        ``mse_m2`` (m^2), ``mean_distance_m`` (m) and ``n``.
    """
    if len(u) == 0:
        return {"mse_m2": None, "mean_distance_m": None, "n": 0}
    y_hat = model.predict(u)
    return {"mse_m2": mse_m2(y_hat, y), "mean_distance_m": mean_distance_m(y_hat, y), "n": int(len(u))}


def workspace_size_m(p_tip: np.ndarray) -> float:
    """Diagonal of the axis-aligned bounding box of tip positions.

    Parameters
    ----------
    p_tip : numpy.ndarray
        Tip positions, shape (N, 3), m; of (N, 3K) outputs of K markers, the first three
        columns (the tip) count.

    Returns
    -------
    float
        The diagonal, m.
    """
    p_tip = np.asarray(p_tip, dtype=float)
    if p_tip.ndim == 2 and p_tip.shape[1] > 3:
        p_tip = p_tip[:, :3]
    return float(np.linalg.norm(p_tip.max(axis=0) - p_tip.min(axis=0)))
