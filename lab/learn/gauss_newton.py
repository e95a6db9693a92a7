"""The Gauss-Newton products of Levenberg-Marquardt, J^T J and J^T e, without forming all of J.

LM and Bayesian regularisation (:mod:`lab.learn.lm`, :mod:`lab.learn.bayes`) need, every
epoch, J^T J and J^T e for J = dy/dtheta, the (N n_y) x n_params Jacobian of
:meth:`lab.learn.mlp.MLP.parameter_jacobian` (units of y per unit of theta), and the errors
e = y(u) - y_data (m). Forming J and multiplying costs N n_y n_params^2 / 2; the layers'
structure makes most of it unnecessary:

* **the output layer** (linear, the last n_y (h + 1) parameters, h the last hidden width):
  dy_k / dW_L[k', j] = delta_kk' a_j / g_k, so its block of J^T J is block diagonal, the
  same (h + 1)^2 Gram matrix A^T A of the last activations A = [a_{L-1}, 1] for every output
  (scaled by 1 / g_k^2, g the output gains), and its coupling to the hidden parameters is
  one (p_h x (h + 1)) product per output;
* **one hidden layer**: dy_k / dW_1[j, m] = V[k, j] s_j(u) x_m with V = W_2 / g and s the
  slopes, so the hidden block is C o (Z^T Z) (elementwise), Z[i, (j, m)] = s_j x_m (N rows,
  not N n_y) and C = V^T V expanded to the columns: n_y times fewer operations;
* deeper networks form the hidden layers' part of J only (N n_y x p_h) and multiply it by
  BLAS ``syrk``.

:func:`gauss_newton` returns the upper triangle (what the Cholesky solves and eigenvalues
read), in :meth:`lab.learn.mlp.MLP.get_params` order, built in chunks of samples whose
temporaries stay under a memory bound. The reference it is checked against is the dense
product of :meth:`lab.learn.mlp.MLP.parameter_jacobian` (tests/test_gauss_newton.py).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.blas import dsyrk, ssyrk

from lab.learn.mlp import MLP, _slope

__all__ = ["gauss_newton"]


def _array(work, name, shape, dtype=np.float64, order="C", zero=False) -> np.ndarray:
    """An array for ``name``: new, or ``work``'s from an earlier call of the same shape
    (fresh memory costs page faults on every epoch; kept memory does not)."""
    if work is None:
        return (np.zeros if zero else np.empty)(shape, dtype, order=order)
    key = (name, tuple(shape), np.dtype(dtype).char, order)
    out = work.get(key)
    if out is None:
        out = work[key] = np.empty(shape, dtype, order=order)
    if zero:
        out.fill(0.0)
    return out


def _early_jacobian(net: MLP, acts, n_y: int, p_e: int, work=None) -> np.ndarray:
    """The columns of J of every hidden layer but the last, in units of y, (n, n_y, p_e)."""
    n = len(acts[0])
    deltas = net._backward(acts)  # deltas[l] = d y_n / d z_{l+1}, (n, n_y, n_{l+1})
    J = _array(work, "J", (n, n_y, p_e))
    k = 0
    for l, w in enumerate(net.weights[:-2]):
        d = deltas[l] / net.y_gain[None, :, None]  # units of y
        np.multiply(d[:, :, :, None], acts[l][:, None, None, :], out=J[:, :, k : k + w.size].reshape(n, n_y, *w.shape))
        k += w.size
        J[:, :, k : k + w.shape[0]] = d
        k += w.shape[0]
    return J


def gauss_newton(net: MLP, u: np.ndarray, y: np.ndarray, max_mb: float = 256.0, single: bool = False, work=None):
    """The sum of squared errors, J^T e and the upper triangle of J^T J of ``net`` on (u, y).

    Parameters
    ----------
    net : MLP
        The network at its current parameters (n_params of them).
    u : numpy.ndarray
        Inputs, shape (N, n_u), rad.
    y : numpy.ndarray
        Targets, shape (N, n_y), m.
    max_mb : float
        Memory bound of the chunks' largest temporary, MB.
    single : bool
        Multiply J's blocks in float32 (twice BLAS's speed; J^T J to about 1e-6 relative,
        what a curvature estimated from a sample of rows can take: :mod:`lab.learn.lm_subsample`);
        J^T e and the sum of squares stay float64.
    work : dict, optional
        Arrays kept between calls (a trainer's epochs): the temporaries and the result are
        reused, not allocated anew. The returned ``JJ`` then belongs to ``work``: the next
        call with it overwrites it.

    Returns
    -------
    sse : float
        sum of e^2 over samples and outputs, m^2 (e = y(u) - y).
    JE : numpy.ndarray
        J^T e, shape (n_params,), m^2 per unit of theta.
    JJ : numpy.ndarray
        J^T J, shape (n_params, n_params), Fortran order, upper triangle filled (the
        strictly lower one is zero), m^2 per unit of theta squared.
    """
    sizes = net.layer_sizes
    n_y, h, n_p = sizes[-1], sizes[-2], net.n_params
    deep = len(sizes) > 2  # a hidden layer at all
    n_in = sizes[-3] if deep else 0  # inputs of the last hidden layer
    p_q = h * (n_in + 1) if deep else 0  # the last hidden layer's parameters
    p_e = n_p - p_q - n_y * (h + 1)  # every earlier layer's
    g = net.y_gain
    V = net.weights[-1] / g[:, None]  # dy / d a_{L-1}, (n_y, h), units of y
    per_sample = max(p_q + 2 * (h + 1), n_y * p_e)
    chunk = max(1, int(max_mb * 2**20 // (8 * per_sample)))
    dt = np.float32 if single else np.float64
    z = {"dtype": dt, "zero": True}
    acc = {
        "dtype": dt,
        "syrk": ssyrk if single else dsyrk,
        "work": work,
        "M": _array(work, "M", (h + 1, h + 1), order="F", **z),  # A^T A, A = [a_{L-1}, 1]
        "ZZ": _array(work, "ZZ", (p_q, p_q), order="F", **z),  # Z^T Z
        "ZA": _array(work, "ZA", (p_q, h + 1), **z),  # Z^T A
        "EE": _array(work, "EE", (p_e, p_e), order="F", **z),  # J_e^T J_e
        "EA": _array(work, "EA", (n_y * p_e, h + 1), **z),  # J_e,k^T A per output k, stacked
        "EZ": _array(work, "EZ", (n_y * p_e, p_q), **z),  # J_e,k^T Z per output k, stacked
        "JE_e": np.zeros(p_e),
        "JE_q": np.zeros(p_q),
        "JE_w": np.zeros((n_y, h)),
        "JE_b": np.zeros(n_y),
    }
    sse = 0.0
    for s in range(0, len(u), chunk):
        acts, y_n = net._forward(u[s : s + chunk])
        e = net._denormalise(y_n) - y[s : s + chunk]  # (n, n_y), m
        sse += float(np.vdot(e, e))
        _accumulate(net, acc, acts, e, V, g, h, n_in, p_q, p_e)
    return sse, *_assemble(acc, V, g, h, n_in, p_q, p_e, n_y)


def _accumulate(net, acc, acts, e, V, g, h, n_in, p_q, p_e):
    """Add one chunk of samples to the blocks of J^T J and J^T e."""
    n, n_y, dt, syrk, work = len(e), e.shape[1], acc["dtype"], acc["syrk"], acc["work"]
    a = acts[-1]
    A = _array(work, "A", (n, h + 1), dt)
    A[:, :h], A[:, h] = a, 1.0
    acc["M"] = syrk(1.0, A.T, beta=1.0, c=acc["M"], overwrite_c=1)
    eg = e / g
    acc["JE_w"] += eg.T @ a
    acc["JE_b"] += eg.sum(axis=0)
    if not p_q:
        return
    # the last hidden layer: J[(i, k), (j, m)] = V[k, j] Z[i, (j, m)], Z = slope_j x~_m
    x, sl = acts[-2], _slope(net.activation, a)  # (n, n_in), (n, h)
    Z = _array(work, "Z", (n, p_q), dt)
    Zw = Z[:, : h * n_in].reshape(n, h, n_in)
    if n_in < h:  # a few long products beat many short ones
        for m in range(n_in):
            np.multiply(sl, x[:, m, None], out=Zw[:, :, m], casting="same_kind")
    else:
        np.multiply(sl[:, :, None], x[:, None, :], out=Zw, casting="same_kind")
    Z[:, h * n_in :] = sl
    acc["ZZ"] = syrk(1.0, Z.T, beta=1.0, c=acc["ZZ"], overwrite_c=1)
    acc["ZA"] += np.matmul(Z.T, A, out=_array(work, "ZA+", (p_q, h + 1), dt))
    ES = (e @ V) * sl  # (n, h): J_q^T e = sum_i ES[i, j] x~[i, m]
    acc["JE_q"][: h * n_in] += (ES.T @ x).ravel()
    acc["JE_q"][h * n_in :] += ES.sum(axis=0)
    if not p_e:
        return
    J = _early_jacobian(net, acts, n_y, p_e, work)  # (n, n_y, p_e)
    acc["JE_e"] += J.reshape(-1, p_e).T @ e.ravel()
    if dt is not np.float64:
        J = J.astype(dt)
    J2, Jt = J.reshape(-1, p_e), J.reshape(n, n_y * p_e).T  # rows (i, k); columns (i), rows (k, p)
    acc["EE"] = syrk(1.0, J2.T, beta=1.0, c=acc["EE"], overwrite_c=1)
    acc["EA"] += np.matmul(Jt, A, out=_array(work, "EA+", (n_y * p_e, h + 1), dt))
    acc["EZ"] += np.matmul(Jt, Z, out=_array(work, "EZ+", (n_y * p_e, p_q), dt))  # times V[k, unit] later


def _assemble(acc, V, g, h, n_in, p_q, p_e, n_y):
    """J^T e and the upper triangle of J^T J in get_params order from the accumulated blocks."""
    work = acc["work"]
    p_h = p_e + p_q
    n_p = p_h + n_y * (h + 1)
    JJ = _array(work, "JJ", (n_p, n_p), order="F", zero=True)
    w0, b0 = p_h, p_h + n_y * h  # where the output weights (row-major, k then j) and biases start
    M, ig2 = acc["M"], 1.0 / (g * g)
    EA = acc["EA"].reshape(n_y, p_e, h + 1)
    for k in range(n_y):
        w = slice(w0 + k * h, w0 + (k + 1) * h)
        JJ[w, w] = M[:h, :h] * ig2[k]
        JJ[w, b0 + k] = M[:h, h] * ig2[k]
        JJ[b0 + k, b0 + k] = M[h, h] * ig2[k]
        JJ[:p_e, w] = EA[k][:, :h] / g[k]
        JJ[:p_e, b0 + k] = EA[k][:, h] / g[k]
    if p_q:
        units = np.concatenate([np.repeat(np.arange(h), n_in), np.arange(h)])  # the unit j of each column
        q = slice(p_e, p_h)
        C = np.take((V.T @ V)[units], units, axis=1, out=_array(work, "C", (p_q, p_q)))
        np.multiply(C, acc["ZZ"], out=JJ[q, q])
        EZ, part = acc["EZ"].reshape(n_y, p_e, p_q), _array(work, "EZk", (p_e, p_q))
        for k in range(n_y):
            np.multiply(EZ[k], V[k, units], out=part)
            JJ[:p_e, q] += part
            block = (V[k, units] / g[k])[:, None] * acc["ZA"]
            JJ[q, w0 + k * h : w0 + (k + 1) * h] = block[:, :h]
            JJ[q, b0 + k] = block[:, h]
    JJ[:p_e, :p_e] = acc["EE"]
    JE = np.concatenate([acc["JE_e"], acc["JE_q"], acc["JE_w"].ravel(), acc["JE_b"]])
    return JE, JJ
