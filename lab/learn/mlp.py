"""The learned forward model ``y(u)``: a small multilayer perceptron in NumPy float64.

Section II-C of the paper learns the quasi-static forward kinematics, motor angles ``u``
(rad) -> tip position ``y`` (m), and controls the robot through its **network Jacobian**
dy/du (Appendix). This is that network, written for speed on small batches (IK evaluates it
once per target). Layers as MATLAB's ``feedforwardnet``: ``mapminmax`` scaling of u to
[-1, 1], hidden layers sigma(W_l a_{l-1} + b_l) (tanh or logistic; ``W_l`` (n_l, n_{l-1})), a
linear output, and y's scaling undone. The Jacobian is the Appendix's chain rule,

    dy/du = diag(1/g_y) W_L D_{L-1} W_{L-1} ... D_1 W_1 diag(g_u),   D_l = diag(sigma'(z_l)),

accumulated from the output side, batched; the same products give dy/dtheta for
Levenberg-Marquardt (:meth:`MLP.parameter_jacobian`), ``theta`` being, layer by layer, ``W_l``
(row-major) then ``b_l``. Files: :meth:`MLP.save` / :func:`load_model` (``.npz``, no pickle;
:mod:`lab.learn.model_io`); failures raise :class:`ModelFileError`. Layers: docs/design/learn.md.
"""

from __future__ import annotations

import copy

import numpy as np
from scipy.special import expit

from lab.errors import InputError
from lab.learn.model_io import read_model, save_model

ACTIVATIONS = ("tanh", "logistic")
# predict_and_jacobian cuts big batches into pieces whose largest temporary, (piece, n_y,
# width), holds about this many numbers: they stay in cache and their memory is reused.
_CHUNK_ELEMENTS = 2**15


def _activate(name: str, z: np.ndarray) -> np.ndarray:
    return np.tanh(z, out=z) if name == "tanh" else expit(z, out=z)


def _slope(name: str, a: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """sigma'(z) written in terms of the activation a = sigma(z): 1 - a^2 or a (1 - a).
    ``out=a`` overwrites the activations (saves a large temporary)."""
    if name == "tanh":
        s = np.square(a, out=out)
        return np.subtract(1.0, s, out=s)
    s = 1.0 - a
    return np.multiply(a, s, out=s if out is None else out)


def minmax_gain(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``mapminmax`` gain 2 / (hi - lo) per column; 1 where the column is constant.

    Parameters
    ----------
    lo, hi : array_like
        Column minima and maxima, shape (n,), in the column's unit.

    Returns
    -------
    numpy.ndarray
        Gains, shape (n,), per unit of the column.
    """
    span = np.asarray(hi, float) - np.asarray(lo, float)
    safe = np.where(span > 0, span, 2.0)
    return 2.0 / safe


class MLP:
    """Feed-forward network u (n_u,) -> y (n_y,) with mapminmax normalisation.

    Parameters
    ----------
    weights, biases : sequence of array_like
        ``weights[l]`` (n_{l+1}, n_l) and ``biases[l]`` (n_{l+1},), acting on normalised values.
    u_min, u_max : array_like
        The data range of u mapped to [-1, 1], shape (n_u,), units of u (here rad).
    y_min, y_max : array_like
        The data range of y mapped to [-1, 1], shape (n_y,), units of y (here m). Treat the
        four ranges as read-only: the gains are derived once.
    activation : str
        Hidden activation, ``"tanh"`` or ``"logistic"``.
    metadata : dict, optional
        The training record that :mod:`lab.learn.model_io` saves with the model.
    """

    kind = "lab.mlp"  # the file kind (lab.learn.model_io.KIND); every lab model names its kind
    has_jacobian = True

    def __init__(
        self, weights, biases, u_min, u_max, y_min, y_max, activation: str = "tanh", metadata: dict | None = None
    ):
        if activation not in ACTIVATIONS:
            raise InputError(f"activation must be one of {ACTIVATIONS}, got {activation!r}")
        self.weights = [np.array(w, dtype=float) for w in weights]
        self.biases = [np.array(b, dtype=float) for b in biases]
        if not self.weights or len(self.weights) != len(self.biases):
            raise InputError("need one bias vector per weight matrix and at least one layer")
        for l, (w, b) in enumerate(zip(self.weights, self.biases)):
            if w.ndim != 2 or b.shape != (w.shape[0],):
                raise InputError(f"layer {l}: weight {w.shape} and bias {b.shape} do not match")
            if l and w.shape[1] != self.weights[l - 1].shape[0]:
                raise InputError(
                    f"layer {l}: takes {w.shape[1]} inputs but layer {l - 1} has {self.weights[l - 1].shape[0]} outputs"
                )
        self.activation = activation
        self.u_min, self.u_max = np.array(u_min, float), np.array(u_max, float)
        self.y_min, self.y_max = np.array(y_min, float), np.array(y_max, float)
        if self.u_min.shape != (self.n_u,) or self.u_max.shape != (self.n_u,):
            raise InputError(f"u_min/u_max must have shape ({self.n_u},)")
        if self.y_min.shape != (self.n_y,) or self.y_max.shape != (self.n_y,):
            raise InputError(f"y_min/y_max must have shape ({self.n_y},)")
        self.u_gain = minmax_gain(self.u_min, self.u_max)
        self.y_gain = minmax_gain(self.y_min, self.y_max)
        self._J_scale = self.u_gain[None, None, :] / self.y_gain[None, :, None]  # dy/du = J_n * this
        self._piece = max(16, _CHUNK_ELEMENTS // (self.n_y * max(self.layer_sizes)))
        self.metadata = dict(metadata or {})

    # ---- shape ---------------------------------------------------------------------
    @property
    def n_u(self) -> int:
        return self.weights[0].shape[1]

    @property
    def n_y(self) -> int:
        return self.weights[-1].shape[0]

    @property
    def layer_sizes(self) -> tuple[int, ...]:
        """(n_u, hidden..., n_y), e.g. (3, 20, 20, 3)."""
        return (self.n_u, *(w.shape[0] for w in self.weights))

    @property
    def hidden(self) -> tuple[int, ...]:
        return self.layer_sizes[1:-1]

    @property
    def n_params(self) -> int:
        return sum(w.size + b.size for w, b in zip(self.weights, self.biases))

    def __repr__(self) -> str:
        return f"MLP({'-'.join(map(str, self.layer_sizes))}, {self.activation}, {self.n_params} parameters)"

    def copy(self) -> MLP:
        """A deep copy.

        Returns
        -------
        MLP
            The copy, sharing no array with this network.
        """
        return copy.deepcopy(self)

    def save(self, path) -> None:
        """Write to ``path`` (.npz, atomic, no pickle); read back with :func:`load_model`.

        Parameters
        ----------
        path : str or Path
            The model file.
        """
        save_model(self, path)

    # ---- parameters ----------------------------------------------------------------
    def get_params(self) -> np.ndarray:
        """Flat parameter vector theta: per layer W_l row-major, then b_l.

        Returns
        -------
        numpy.ndarray
            theta, shape (n_params,) (a copy).
        """
        return np.concatenate([np.concatenate([w.ravel(), b]) for w, b in zip(self.weights, self.biases)])

    def set_params(self, theta: np.ndarray) -> None:
        """Overwrite all weights and biases from a flat vector (the order of :meth:`get_params`).

        Parameters
        ----------
        theta : array_like
            Shape (n_params,).
        """
        theta = np.asarray(theta, dtype=float)
        if theta.shape != (self.n_params,):
            raise InputError(f"expected {self.n_params} parameters, got shape {theta.shape}")
        k = 0
        for w, b in zip(self.weights, self.biases):
            w[...] = theta[k : k + w.size].reshape(w.shape)
            k += w.size
            b[...] = theta[k : k + b.size]
            k += b.size

    # ---- evaluation ----------------------------------------------------------------
    def _as_batch(self, u) -> tuple[np.ndarray, bool]:
        u = np.asarray(u, dtype=float)
        single = u.ndim == 1
        u2 = u[None, :] if single else u
        if u2.ndim != 2 or u2.shape[1] != self.n_u:
            raise InputError(f"expected u of shape (N, {self.n_u}) or ({self.n_u},), got {u.shape}")
        return u2, single

    def _forward(self, u2: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        """Hidden activations [a_0 (normalised u), a_1, ..., a_{L-1}] and normalised output y_n."""
        a = u2 - self.u_min  # updates in place: every large temporary
        a *= self.u_gain  # costs time at batch sizes of 10^4
        a -= 1.0
        acts = [a]
        for w, b in zip(self.weights[:-1], self.biases[:-1]):
            z = acts[-1] @ w.T
            z += b
            acts.append(_activate(self.activation, z))
        y_n = acts[-1] @ self.weights[-1].T
        y_n += self.biases[-1]
        return acts, y_n

    def _denormalise(self, y_n: np.ndarray) -> np.ndarray:
        return (y_n + 1.0) / self.y_gain + self.y_min

    def _backward(self, acts: list[np.ndarray], overwrite: bool = False) -> list[np.ndarray]:
        """Sensitivities of the normalised output, per layer, batched: the chain rule of the
        Appendix, from the top.

        Returns ``deltas`` with ``deltas[l]`` = d y_n / d z_{l+1} (N, n_y, n_{l+1}), z being
        a layer's net input, except the output layer's, the identity, left as None; and a
        last entry d y_n / d a_0 (N, n_y, n_u). ``overwrite=True`` turns the hidden
        activations in ``acts`` into the slopes sigma'(z) (saves a temporary)."""
        n, n_y, n_layers = len(acts[0]), self.n_y, len(self.weights)
        deltas = [None] * (n_layers + 1)
        w = self.weights[-1]
        grad_a = np.broadcast_to(w, (n, n_y, w.shape[1]))  # d y_n / d a_{L-1} = W_L
        for l in range(n_layers - 1, 0, -1):  # times D_l = diag(sigma'(z_l))
            slope = _slope(self.activation, acts[l], out=acts[l] if overwrite else None)
            deltas[l - 1] = grad_a * slope[:, None, :]
            w = self.weights[l - 1]
            grad_a = (deltas[l - 1].reshape(n * n_y, -1) @ w).reshape(n, n_y, w.shape[1])
        deltas[-1] = grad_a if n_layers > 1 else grad_a.copy()
        return deltas

    def predict(self, u) -> np.ndarray:
        """The network's output.

        Parameters
        ----------
        u : array_like
            Inputs, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        numpy.ndarray
            y, shape (N, n_y) or (n_y,), m.
        """
        u2, single = self._as_batch(u)
        y = self._denormalise(self._forward(u2)[1])
        return y[0] if single else y

    def predict_and_jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """y (N, n_y) and the network Jacobian dy/du (N, n_y, n_u), units of y per unit of u.

        A single u (n_u,) gives y (n_y,) and dy/du (n_y, n_u).

        Parameters
        ----------
        u : array_like
            Inputs, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        y : numpy.ndarray
            Shape (N, n_y) or (n_y,), m.
        J : numpy.ndarray
            dy/du, shape (N, n_y, n_u) or (n_y, n_u), m/rad.
        """
        u2, single = self._as_batch(u)
        if single:
            return self._one(u2[0])
        y, J = np.empty((len(u2), self.n_y)), np.empty((len(u2), self.n_y, self.n_u))
        piece = self._piece
        for s in range(0, len(u2), piece):
            acts, y_n = self._forward(u2[s : s + piece])
            np.multiply(self._backward(acts, overwrite=True)[-1], self._J_scale, out=J[s : s + piece])
            y[s : s + piece] = self._denormalise(y_n)
        return (y[0], J[0]) if single else (y, J)

    def _one(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """y (n_y,) and dy/du (n_y, n_u) for one u (n_u,): the same chain rule with vectors,
        without the batch machinery, whose overhead dominates for one point (the IK's case)."""
        a = (u - self.u_min) * self.u_gain - 1.0
        slopes = []
        for w, b in zip(self.weights[:-1], self.biases[:-1]):
            a = _activate(self.activation, w @ a + b)
            slopes.append(_slope(self.activation, a))
        y_n = self.weights[-1] @ a + self.biases[-1]
        grad = self.weights[-1]
        for w, slope in zip(reversed(self.weights[:-1]), reversed(slopes)):
            grad = (grad * slope) @ w
        return self._denormalise(y_n), grad * self._J_scale[0]

    def jacobian(self, u) -> np.ndarray:
        """The network Jacobian dy/du.

        Parameters
        ----------
        u : array_like
            Inputs, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        numpy.ndarray
            dy/du, shape (N, n_y, n_u) or (n_y, n_u), m/rad.
        """
        return self.predict_and_jacobian(u)[1]

    def parameter_jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """y (N, n_y) and d y / d theta (N * n_y, n_params), row ``i * n_y + k`` = sample i,
        output k, in units of y (the normalisation is folded in); columns follow :meth:`get_params`.

        Parameters
        ----------
        u : array_like
            Inputs, shape (N, n_u), rad.

        Returns
        -------
        y : numpy.ndarray
            Shape (N, n_y), m.
        J : numpy.ndarray
            dy/dtheta, shape (N * n_y, n_params), m per unit of theta.
        """
        u2, _ = self._as_batch(u)
        acts, y_n = self._forward(u2)
        deltas = self._backward(acts)
        n, n_y = len(u2), self.n_y
        J = np.empty((n, n_y, self.n_params))
        k = 0
        deltas[-2] = np.broadcast_to(np.eye(n_y), (n, n_y, n_y))  # output layer: identity
        for l, (w, b) in enumerate(zip(self.weights, self.biases)):
            d, a_prev = deltas[l], acts[l]  # (N, n_y, n_out), (N, n_in)
            np.multiply(
                d[:, :, :, None],
                a_prev[:, None, None, :],  # written in place, no temporary
                out=J[:, :, k : k + w.size].reshape(n, n_y, *w.shape),
            )
            k += w.size
            J[:, :, k : k + b.size] = d
            k += b.size
        J /= self.y_gain[None, :, None]
        return self._denormalise(y_n), J.reshape(n * n_y, self.n_params)

    def gradient(self, u, dL_dy: np.ndarray) -> np.ndarray:
        """Vector-Jacobian product: sum_{i,k} dL_dy[i, k] * d y_k(u_i) / d theta (n_params,).

        Plain backpropagation (no (N n_y, n_params) matrix), for first-order training on
        large datasets.

        Parameters
        ----------
        u : array_like
            Inputs, shape (N, n_u), rad.
        dL_dy : numpy.ndarray
            The loss gradient with respect to y, shape (N, n_y), per m.

        Returns
        -------
        numpy.ndarray
            dL/dtheta, shape (n_params,).
        """
        u2, _ = self._as_batch(u)
        acts, _ = self._forward(u2)
        delta = np.asarray(dL_dy, float) / self.y_gain  # d L / d y_n
        grads = []
        for l in range(len(self.weights) - 1, -1, -1):
            grads.append(np.concatenate([(delta.T @ acts[l]).ravel(), delta.sum(axis=0)]))
            if l:
                delta = (delta @ self.weights[l]) * _slope(self.activation, acts[l])
        return np.concatenate(grads[::-1])


def load_model(path):
    """Read a model written by :meth:`MLP.save` (``.npz``, no pickle) or, for a file of kind
    ``lab.residual``, a :class:`lab.learn.residual.ResidualModel` (same forward-map
    interface); raises :class:`lab.learn.model_io.ModelFileError` naming the file and the
    problem. :func:`lab.learn.models.load_model` (exported as ``lab.learn.load_model``)
    reads every kind of model file."""
    from lab.learn.model_io import file_metadata

    if file_metadata(path).get("kind") == "lab.residual":
        from lab.learn.residual import load_residual

        return load_residual(path, MLP, ACTIVATIONS)
    return MLP(**read_model(path, ACTIVATIONS))
