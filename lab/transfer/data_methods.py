"""Sim-to-real transfer methods that need only data: each takes a network trained on
simulated data (or none) and N real samples, and returns a forward model for IK.

* ``real-only``: a new 3-20-20-3 network trained on the N real samples alone (the
  baseline; LM with a 10 % validation stop from 10 samples on, all N for training below);
* ``finetune`` / ``finetune-last``: the simulation network fine-tuned on the real
  samples, all layers / the output layer only (:mod:`lab.learn.finetune`);
* ``residual``: the simulation network plus a GP model of ``y_real - y_sim``
  (:mod:`lab.learn.residual`).

The physics-based method (``calibrated``: identify the as-built parameters through the
FEM, re-simulate, retrain) is :mod:`lab.transfer.calibrated`. Every method maps the inputs
to whatever outputs the data holds: the tip (N, 3), or every marker (N, 3K), the tip first.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError

__all__ = ["DATA_METHODS", "transfer_model"]

DATA_METHODS = ("real-only", "finetune", "finetune-last", "residual")


def transfer_model(method: str, u_real, y_real, sim_model=None, *, hidden=(20, 20), seed: int = 0):
    """The forward model of ``method`` from real samples and a network trained on simulation.

    Parameters
    ----------
    method : str
        One of :data:`DATA_METHODS`.
    u_real : array_like, shape (N, n_u)
        Real inputs, each in its unit (rad for angles, N for tensions).
    y_real : array_like, shape (N, n_y)
        Real outputs, m: the tip (n_y = 3) or every marker, the tip first (n_y = 3K).
    sim_model : MLP, optional
        The network trained on simulation (not used by ``real-only``).
    hidden : tuple of int
        ``real-only``: hidden layer widths of the new network.
    seed : int
        Seed of the initial weights, splits and GP restarts.

    Returns
    -------
    object
        The forward model (an MLP or a residual model); its ``metadata["transfer"]`` says
        how it was made.
    """
    u, y = np.asarray(u_real, float), np.asarray(y_real, float)
    if method not in DATA_METHODS:
        raise InputError(f"unknown transfer method {method!r}; choose one of {DATA_METHODS}")
    if u.ndim != 2 or y.ndim != 2 or len(u) != len(y) or len(u) == 0:
        raise InputError(f"expected u_real (N, n_u) and y_real (N, n_y) with the same N >= 1, got {u.shape}, {y.shape}")
    if method == "real-only":
        from lab.learn.train import train

        ratios = (0.9, 0.1, 0.0) if len(u) >= 10 else (1.0, 0.0, 0.0)
        model = train(u, y, hidden, ratios=ratios, seed=seed).model
    elif sim_model is None:
        raise InputError(f"method {method!r} starts from a network trained on simulation: give one")
    elif method == "residual":
        from lab.learn.residual import fit_residual

        model = fit_residual(sim_model, u, y, seed=seed)
    else:
        from lab.learn.finetune import finetune

        model = finetune(sim_model, u, y, last_layer_only=method == "finetune-last", seed=seed)
    model.metadata["transfer"] = {"method": method, "n_real": len(u), "seed": seed}
    return model
