"""A new network sized for its data, initialised like MATLAB's ``feedforwardnet``.

:func:`init_mlp` sets the ``mapminmax`` ranges of a :class:`lab.learn.mlp.MLP` to the data's
column ranges and draws Nguyen-Widrow weights (MATLAB's ``initnw``): each hidden neuron's
weights have magnitude 0.7 n^(1/n_in) in a random direction and the biases are spread so
that the neurons' active regions tile the input range; the linear output layer gets the
same rule with [-1, 1] as its active range. The draw is deterministic for an integer seed.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.learn.mlp import ACTIVATIONS, MLP

__all__ = ["init_mlp"]

# Net-input interval over which each activation is "active" (MATLAB's tansig/logsig
# 'active' ranges) and the interval its output covers; used by the Nguyen-Widrow init.
_ACTIVE_RANGE = {"tanh": (-2.0, 2.0), "logistic": (-4.0, 4.0)}
_OUTPUT_RANGE = {"tanh": (-1.0, 1.0), "logistic": (0.0, 1.0)}


def _nguyen_widrow(
    rng: np.random.Generator, n_out: int, in_range: tuple[float, float], n_in: int, active: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """MATLAB ``initnw`` for one layer: weights of magnitude 0.7 n_out^(1/n_in) in random
    directions, biases spread evenly so the neurons' active regions tile the input range."""
    mag = 0.7 * n_out ** (1.0 / n_in)
    w = rng.uniform(-1.0, 1.0, (n_out, n_in))
    w *= mag / np.linalg.norm(w, axis=1, keepdims=True)
    b = mag * np.linspace(-1.0, 1.0, n_out) * np.sign(w[:, 0]) if n_out > 1 else np.zeros(1)
    half, mid = 0.5 * (active[1] - active[0]), 0.5 * (active[1] + active[0])
    w, b = half * w, half * b + mid  # net inputs [-1, 1] -> active range
    scale = 2.0 / (in_range[1] - in_range[0])  # inputs in_range -> [-1, 1]
    shift = 1.0 - in_range[1] * scale
    return w * scale, w @ np.full(n_in, shift) + b


def init_mlp(u, y, hidden=(20, 20), activation: str = "tanh", seed: int | np.random.Generator = 0) -> MLP:
    """A new network sized for data u (N, n_u), y (N, n_y), initialised like MATLAB.

    Normalisation ranges are the columns' min/max over the given data (MATLAB configures
    ``mapminmax`` on all data passed to ``train``). Hidden layers get Nguyen-Widrow
    weights (``initnw``) for the activation's active range; the linear output layer gets
    the same rule with its target range [-1, 1] as the active range. Deterministic for
    an integer ``seed``.

    Parameters
    ----------
    u : array_like
        Inputs, shape (N, n_u), e.g. motor angles in rad.
    y : array_like
        Outputs, shape (N, n_y), e.g. tip positions in m.
    hidden : tuple of int
        Hidden layer widths.
    activation : str
        ``"tanh"`` or ``"logistic"``.
    seed : int or numpy.random.Generator
        The random stream of the weights.

    Returns
    -------
    MLP
        The untrained network, layers (n_u, hidden..., n_y).
    """
    u, y = np.asarray(u, float), np.asarray(y, float)
    if u.ndim != 2 or y.ndim != 2 or len(u) != len(y) or len(u) == 0:
        raise InputError(f"expected u (N, n_u) and y (N, n_y) with N >= 1, got {u.shape} and {y.shape}")
    if activation not in ACTIVATIONS:
        raise InputError(f"activation must be one of {ACTIVATIONS}, got {activation!r}")
    hidden = tuple(int(h) for h in hidden)
    if any(h < 1 for h in hidden):
        raise InputError(f"hidden layer widths must be positive, got {hidden}")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    sizes = (u.shape[1], *hidden, y.shape[1])
    weights, biases, in_range = [], [], (-1.0, 1.0)
    for l in range(len(sizes) - 1):
        is_output = l == len(sizes) - 2
        active = (-1.0, 1.0) if is_output else _ACTIVE_RANGE[activation]
        w, b = _nguyen_widrow(rng, sizes[l + 1], in_range, sizes[l], active)
        weights.append(w)
        biases.append(b)
        in_range = _OUTPUT_RANGE[activation]
    return MLP(weights, biases, u.min(axis=0), u.max(axis=0), y.min(axis=0), y.max(axis=0), activation)
