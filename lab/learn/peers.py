"""scikit-learn peers of the network, side by side with it: GP, k-NN, MLPRegressor.

The paper cites Gaussian-process regression and k-nearest-neighbour models as related
work; these are those models with the network's forward-map interface
(:mod:`lab.learn.peers_base`), so the same error metrics, studies and inverse kinematics
take any of them:

* :func:`fit_gpr` -- ``GaussianProcessRegressor`` with an exact closed-form Jacobian and a
  predictive standard deviation (:mod:`lab.learn.peers_gp`; refuses more than
  :data:`GP_MAX_SAMPLES` samples unless told to subsample);
* :func:`fit_knn` -- ``KNeighborsRegressor`` (:class:`KNNModel`): **no useful Jacobian**
  (kinks and jumps where the neighbour set changes), so IK with it must be derivative-free;
* :func:`fit_sklearn_mlp` -- ``MLPRegressor``, its Jacobian from its weights (:mod:`lab.learn.peers_mlp`).

:func:`load_peer` reads any of the three (``.npz``, no pickle; kinds ``lab.gpr``, ``lab.knn``, ``lab.sklearn_mlp``).
"""

from __future__ import annotations

import time

import numpy as np

from lab.errors import InputError
from lab.learn.model_io import ModelFileError, file_metadata
from lab.learn.peers_base import UNITS, PeerModel, check_data, float_array, input_range, peer_arrays
from lab.learn.peers_gp import GP_MAX_SAMPLES, GPR_KIND, GPRModel, fit_gpr, load_gpr
from lab.learn.peers_mlp import SKLEARN_MLP_KIND, SklearnMLPModel, fit_sklearn_mlp, load_sklearn_mlp

__all__ = [
    "GP_MAX_SAMPLES",
    "GPRModel",
    "KNNModel",
    "PEER_KINDS",
    "SklearnMLPModel",
    "fit_gpr",
    "fit_knn",
    "fit_sklearn_mlp",
    "load_peer",
]

KNN_KIND = "lab.knn"
KNN_WEIGHTS = ("distance", "uniform")
#: Leaf size of the k-d tree (scikit-learn's default).
KNN_LEAF = 30


class KNNModel(PeerModel):
    """k-nearest-neighbour regression over the stored samples ``u_train`` (N, n_u) rad,
    ``y_train`` (N, n_y) m, distances measured on the scaled inputs. ``weights``:
    "distance" (inverse-distance average of the ``n_neighbors`` nearest, exact at a
    training sample) or "uniform" (their plain mean).

    Parameters
    ----------
    u_min, u_max : array_like
        The input range the distances are scaled by, shape (n_u,), rad.
    u_train : array_like
        Stored commands, shape (N, n_u), rad.
    y_train : array_like
        Stored tips, shape (N, n_y), m.
    n_neighbors : int
        k, 1 to N.
    weights : str
        ``"distance"`` or ``"uniform"``.
    metadata : dict, optional
        The training record, saved with the file.
    """

    kind = KNN_KIND
    has_jacobian = False

    def __init__(self, u_min, u_max, u_train, y_train, n_neighbors: int = 5, weights: str = "distance", metadata=None):
        from sklearn.neighbors import KDTree, KNeighborsRegressor

        super().__init__(u_min, u_max, metadata)
        self.u_train, self.y_train = np.array(u_train, float), np.array(y_train, float)
        if self.u_train.ndim != 2 or self.u_train.shape[1] != self.n_u or self.y_train.ndim != 2:
            raise InputError(f"u_train must be (N, {self.n_u}) and y_train (N, n_y)")
        if len(self.y_train) != len(self.u_train):
            raise InputError(f"u_train has {len(self.u_train)} rows, y_train {len(self.y_train)}")
        if weights not in KNN_WEIGHTS:
            raise InputError(f"weights must be one of {KNN_WEIGHTS}, got {weights!r}")
        if not 1 <= int(n_neighbors) <= len(self.u_train):
            raise InputError(f"n_neighbors must be between 1 and the {len(self.u_train)} samples, got {n_neighbors}")
        self.n_neighbors, self.weights = int(n_neighbors), weights
        fit = self.metadata.setdefault("training", {})  # the file needs them to rebuild the model
        fit.update(n_neighbors=self.n_neighbors, weights=weights)
        # "fitting" stores the samples in a search tree: rebuilt after loading, nothing pickled.
        # Predictions query the estimator's k-d tree (the same tree, built alike) directly and
        # weight as it does: its predict() spends ~0.5 ms per call checking its input, which
        # was 90 % of a derivative-free IK's time (thousands of small batches).
        x_train = self.scale(self.u_train)
        self.estimator = KNeighborsRegressor(self.n_neighbors, weights=weights, algorithm="kd_tree", leaf_size=KNN_LEAF)
        self.estimator.fit(x_train, self.y_train)
        self.tree = KDTree(x_train, leaf_size=KNN_LEAF)

    n_y = property(lambda self: self.y_train.shape[1])

    def _predict(self, u2):
        dist, ind = self.tree.query(self.scale(u2), k=self.n_neighbors)
        if self.weights == "uniform":
            return np.mean(self.y_train[ind], axis=1)
        with np.errstate(divide="ignore"):
            w = 1.0 / dist
        at_sample = np.isinf(w)  # at a stored sample: that sample alone (as scikit-learn does)
        rows = np.any(at_sample, axis=1)
        w[rows] = at_sample[rows]
        return np.sum(self.y_train[ind] * w[:, :, None], axis=1) / np.sum(w, axis=1)[:, None]

    def _predict_and_jacobian(self, u2):
        raise InputError(
            "a k-NN model has no useful Jacobian: its prediction is a weighted average of stored samples that "
            "changes with kinks and jumps where the set of nearest neighbours changes, and its derivative is zero "
            "or undefined almost everywhere; use a derivative-free IK with it (or a model with a Jacobian)"
        )

    def _arrays(self) -> dict:
        return {"u_train": self.u_train, "y_train": self.y_train}


def fit_knn(u, y, n_neighbors: int = 5, *, weights: str = "distance") -> KNNModel:
    """k-NN forward model of commands ``u`` (N, n_u) rad and tips ``y`` (N, n_y) m.

    ``weights="distance"`` by default: on smooth, nearly noise-free kinematics (FEM data,
    motion capture at ~0.1 mm) the inverse-distance average interpolates, reproducing a
    sample exactly at its command, whereas the uniform mean of the k neighbours is biased
    towards their centroid by about the sample spacing (measured when the peers were
    compared: distance weights are more accurate on both three-cable datasets).

    Parameters
    ----------
    u : array_like
        Commands, shape (N, n_u), rad.
    y : array_like
        Tips, shape (N, n_y), m.
    n_neighbors : int
        k, 1 to N.
    weights : str
        ``"distance"`` or ``"uniform"``.

    Returns
    -------
    KNNModel
        The model over the N samples.
    """
    u, y = check_data(u, y, need=1)
    t0 = time.perf_counter()
    meta = {"model": "KNeighborsRegressor", "units": dict(UNITS), "training": {"n_samples": len(u)}}
    model = KNNModel(u.min(axis=0), u.max(axis=0), u, y, n_neighbors, weights, meta)
    model.metadata["training"]["wall_s"] = time.perf_counter() - t0
    return model


def _load_knn(path) -> KNNModel:
    arrays, meta, path = peer_arrays(path, KNN_KIND)
    u_min, u_max = input_range(arrays, path)
    u_train = float_array(arrays, "u_train", path, (None, len(u_min)))
    y_train = float_array(arrays, "y_train", path, (len(u_train), None))
    fit = meta.get("training", {}) if isinstance(meta.get("training"), dict) else {}
    k, weights = fit.get("n_neighbors"), fit.get("weights")
    if not isinstance(k, int) or isinstance(k, bool) or weights not in KNN_WEIGHTS:
        raise ModelFileError(f"{path}: metadata lacks training.n_neighbors / training.weights")
    try:
        return KNNModel(u_min, u_max, u_train, y_train, k, weights, meta)
    except InputError as err:
        raise ModelFileError(f"{path}: {err}") from None


PEER_KINDS = {GPR_KIND: load_gpr, KNN_KIND: _load_knn, SKLEARN_MLP_KIND: load_sklearn_mlp}


def load_peer(path) -> GPRModel | KNNModel | SklearnMLPModel:
    """Read a peer model file (kind ``lab.gpr``, ``lab.knn`` or ``lab.sklearn_mlp``);
    :class:`ModelFileError` names the file and the problem (missing, corrupt, another
    kind, a missing or malformed array).

    Parameters
    ----------
    path : str or Path
        The model file.

    Returns
    -------
    GPRModel, KNNModel or SklearnMLPModel
        The model, by the file's kind.
    """
    kind = file_metadata(path).get("kind")
    if kind not in PEER_KINDS:
        raise ModelFileError(f"{path}: kind {kind!r} is not a peer model ({', '.join(PEER_KINDS)})")
    return PEER_KINDS[kind](path)
