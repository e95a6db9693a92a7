"""Fine-tuning a simulation-trained network on a few real samples (paper, Section VI-B).

The paper proposes to "first train a network on a large amount of simulated data, and then
fine-tune on real data". With N real samples (3N residuals) and 563 parameters, plain
Levenberg-Marquardt would fit the samples exactly and move the network anywhere between
them. The rule against over-fitting used here is a **prior towards the simulated weights**:
:func:`finetune` minimises

    F(theta) = |e(theta)|^2 / N_e + lam |theta - theta_sim|^2

(``e`` the residuals on the real samples in metres, ``N_e = 3N``) by Levenberg-Marquardt, with
``lam`` **chosen by cross-validation** on the real samples (leave-one-out below 10 samples,
else 5-fold) over a log grid, then the fit redone on all N with that ``lam``.
``last_layer_only``: only the output layer moves (63 parameters for 3-20-20-3); the problem
is then linear least squares and LM solves it in one step.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError

__all__ = ["LAMBDA_GRID", "finetune", "finetune_fixed"]

#: Candidate prior weights lam (1/m^2 scale of the data term over parameter units).
LAMBDA_GRID = tuple(10.0**k for k in range(-10, 0))


def _free_mask(model, last_layer_only: bool) -> np.ndarray:
    mask = np.zeros(model.n_params, bool)
    if last_layer_only:
        n_last = model.weights[-1].size + model.biases[-1].size
        mask[-n_last:] = True  # get_params orders layers first to last
    else:
        mask[:] = True
    return mask


def finetune_fixed(model, u, y, lam: float, last_layer_only: bool = False, max_iter: int = 100):
    """Fine-tune a copy of ``model`` on ``u`` (N, n_u) rad, ``y`` (N, n_y) m with the
    prior weight ``lam`` fixed; returns the new model.

    Parameters
    ----------
    model : MLP
        The network trained on simulation (not changed).
    u : numpy.ndarray
        Real commands, shape (N, n_u), rad.
    y : numpy.ndarray
        Real tips, shape (N, n_y), m.
    lam : float
        Weight of the prior towards the simulation's weights.
    last_layer_only : bool
        Fine-tune the output layer only.
    max_iter : int
        Most optimiser iterations.

    Returns
    -------
    MLP
        The fine-tuned copy.
    """
    net = model.copy()
    theta0 = net.get_params()
    free = _free_mask(net, last_layer_only)
    n_e = y.size

    def objective(theta):
        net.set_params(theta)
        e = (net.predict(u) - y).ravel()
        return e @ e / n_e + lam * np.sum((theta - theta0) ** 2)

    theta, mu = theta0.copy(), 1e-3
    f = objective(theta)
    for _ in range(max_iter):
        net.set_params(theta)
        y_hat, J = net.parameter_jacobian(u)
        e, Jf = (y_hat - y).ravel(), J[:, free]
        g = Jf.T @ e / n_e + lam * (theta - theta0)[free]
        solve = _damped_solver(Jf, n_e, lam, g)
        improved = False
        while mu < 1e10:
            step = np.zeros_like(theta)
            step[free] = solve(mu)
            if not np.all(np.isfinite(step)):
                mu *= 10
                continue
            f_new = objective(theta + step)
            if f_new < f:
                improved = f - f_new > 1e-12 * max(f, 1e-30)
                theta, f, mu = theta + step, f_new, max(mu * 0.1, 1e-20)
                break
            mu *= 10
        if not improved:
            break
    net.set_params(theta)
    return net


def _damped_solver(Jf: np.ndarray, n_e: int, lam: float, g: np.ndarray):
    """mu -> the LM step -(Jf^T Jf / n_e + (lam + mu) I)^-1 g.

    With fewer residuals than free parameters (a few real samples, all layers free), from
    the eigendecomposition of the small Gram matrix Jf Jf^T = U diag(w) U^T (w = s^2 of the
    thin SVD Jf = U diag(s) V^T): the step -V diag(1 / (w / n_e + c)) V^T g - (g - V V^T g) / c,
    c = lam + mu, is Jf^T U diag(1 / (n_e c (w / n_e + c))) U^T Jf g - g / c, so each damping
    tried costs two products instead of a solve with the (P, P) normal matrix (563 x 563 for
    3-20-20-3), and the setup one (R, R) eigendecomposition instead of an SVD of Jf (R x P:
    measured 72 x 563, 5x faster, the same steps to 1e-15 relative; a direction of small w,
    where V = Jf^T U / s would be inexact, enters with the weight of the null space, 1 / c);
    otherwise (the output layer alone) by that solve.
    """
    n_rows, n_free = Jf.shape
    if n_rows < n_free:
        w, U = np.linalg.eigh(Jf @ Jf.T)
        JtU, UtJg = Jf.T @ U, U.T @ (Jf @ g)

        def solve(mu):
            c = lam + mu
            return JtU @ (UtJg / (n_e * c * (w / n_e + c))) - g / c

        return solve
    A = Jf.T @ Jf / n_e + lam * np.eye(n_free)

    def solve(mu):
        try:
            return np.linalg.solve(A + mu * np.eye(n_free), -g)
        except np.linalg.LinAlgError:
            return np.full(n_free, np.nan)

    return solve


def _folds(n: int, seed: int) -> list[np.ndarray]:
    order = np.random.default_rng(seed).permutation(n)
    k = n if n < 10 else 5
    return [order[i::k] for i in range(k)]


def finetune(
    model,
    u_real,
    y_real,
    *,
    last_layer_only: bool = False,
    lambdas=LAMBDA_GRID,
    seed: int = 0,
    max_iter: int = 100,
):
    """Fine-tune ``model`` (an :class:`lab.learn.mlp.MLP` trained on simulation) on the real
    samples ``u_real`` (N, n_u) rad, ``y_real`` (N, n_y) m, N >= 2; the prior weight is chosen
    by cross-validation from ``lambdas``. Returns the new model; its
    ``metadata["finetune"]`` records the chosen ``lam`` and every candidate's CV error (m).

    Parameters
    ----------
    model : MLP
        The network trained on simulation (not changed).
    u_real : array_like
        Real commands, shape (N, n_u), rad.
    y_real : array_like
        Real tips, shape (N, n_y), m.
    last_layer_only : bool
        Fine-tune the output layer only.
    lambdas : sequence of float
        Candidate prior weights.
    seed : int
        Seed of the cross-validation folds.
    max_iter : int
        Most optimiser iterations per fit.

    Returns
    -------
    MLP
        The fine-tuned copy.
    """
    u, y = np.asarray(u_real, float), np.asarray(y_real, float)
    if u.ndim != 2 or u.shape[1] != model.n_u or y.shape != (len(u), model.n_y):
        raise InputError(f"expected u_real (N, {model.n_u}) and y_real (N, {model.n_y}), got {u.shape} and {y.shape}")
    if len(u) < 2:
        raise InputError(
            f"fine-tuning needs at least 2 real samples to choose its prior by cross-validation, got {len(u)}"
        )
    folds = _folds(len(u), seed)
    cv = []
    for lam in lambdas:
        dist = []
        for test in folds:
            train = np.setdiff1d(np.arange(len(u)), test)
            net = finetune_fixed(model, u[train], y[train], lam, last_layer_only, max_iter)
            dist.extend(np.linalg.norm(net.predict(u[test]) - y[test], axis=1))
        cv.append(float(np.mean(dist)))
    best = float(lambdas[int(np.argmin(cv))])
    net = finetune_fixed(model, u, y, best, last_layer_only, max_iter)
    net.metadata = {
        **model.metadata,
        "finetune": {
            "method": "finetune-last" if last_layer_only else "finetune",
            "n_real": len(u),
            "lambda": best,
            "cv_mean_distance_m": dict(zip(map(float, lambdas), cv)),
            "folds": len(folds),
        },
    }
    return net
