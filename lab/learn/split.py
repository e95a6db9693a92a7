"""Training the forward model: data splits, MATLAB-faithful Levenberg-Marquardt, one entry point.

The paper trained its networks with MATLAB's Deep Learning Toolbox (``feedforwardnet`` +
``trainlm``). :func:`train_lm` reproduces ``trainlm`` with its parameters

    mu = 1e-3, mu_dec = 0.1, mu_inc = 10, mu_max = 1e10, epochs = 1000,
    max_fail = 6, min_grad = 1e-6 (the paper's value; MATLAB's default is 1e-7), goal = 0

and its semantics, epoch by epoch:

1. **Stop checks**, in MATLAB's order: performance goal met, maximum epoch reached,
   gradient ``2 |J^T e| / N_e`` below ``min_grad``, ``mu >= mu_max``, or ``max_fail``
   consecutive validation failures. Whatever the reason, the network returned is the
   **best one seen**: lowest validation MSE (lowest training MSE without a validation set).
2. **Step**: solve ``(J^T J / N_e + mu I) dtheta = -J^T e / N_e`` (Cholesky). If the
   training MSE decreases, accept and set ``mu <- max(mu * mu_dec, 1e-20)``; otherwise
   ``mu <- mu * mu_inc`` and retry, until ``mu > mu_max``. A matrix that is not
   numerically positive definite counts as a failed trial (MATLAB: singular-matrix warning).
3. **Validation**: MSE on the validation set; lower than the best so far -> new best and
   ``val_fail = 0``; higher -> ``val_fail += 1``; equal -> unchanged.

Errors ``e = y(u) - y_data`` are in the data's units (metres), the performance is MATLAB's
``mse`` (mean over samples *and* coordinates, ``N_e = N * n_y`` elements), as with
``feedforwardnet``'s default ``performParam.normalization = 'none'``. The Jacobian
``J = d y / d theta`` comes in closed form from :meth:`lab.learn.mlp.MLP.parameter_jacobian`.
When there are more parameters than residuals the identical step is computed in the
kernel form ``dtheta = -J^T (J J^T + mu N_e I)^{-1} e`` (cheaper: an N_e x N_e system).

Splits follow MATLAB ``dividerand``: a random permutation, ``round(ratio * N)`` samples
for validation and test, the rest for training. :func:`train` does split + init + fit
with one seeded random stream, so a seed fixes everything. Adam and L-BFGS for large
datasets live in :mod:`lab.learn.gradient`; error metrics and studies in :mod:`lab.learn.studies`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError


@dataclass
class Split:
    """Sample indices of the training, validation and test sets (sorted, disjoint)."""

    train: np.ndarray
    validation: np.ndarray
    test: np.ndarray

    def sizes(self) -> dict:
        return {"train": len(self.train), "validation": len(self.validation), "test": len(self.test)}


def divide_random(n: int, ratios=(0.7, 0.15, 0.15), seed: int | np.random.Generator = 0) -> Split:
    """MATLAB ``dividerand``: ratios (train, validation, test) are normalised by their sum;
    validation and test get ``round(ratio * n)`` samples, training the rest."""
    r = np.asarray(ratios, dtype=float)
    if r.shape != (3,) or np.any(r < 0) or not np.all(np.isfinite(r)) or r[0] <= 0:
        raise InputError(
            f"split ratios must be 3 non-negative numbers (train, validation, test) with train > 0, got {tuple(ratios)}"
        )
    r = r / r.sum()
    n_val, n_test = int(round(r[1] * n)), int(round(r[2] * n))
    n_train = n - n_val - n_test
    if n_train < 1:
        raise InputError(f"split {tuple(ratios)} of {n} samples leaves no training samples")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    perm = rng.permutation(n)
    return Split(np.sort(perm[:n_train]), np.sort(perm[n_train : n_train + n_val]), np.sort(perm[n_train + n_val :]))
