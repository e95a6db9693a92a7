"""Saving and loading :class:`lab.learn.mlp.MLP` as ``.npz`` (NumPy arrays + a JSON string; no pickle).

Arrays: ``W0, b0, W1, b1, ...`` (normalised-space weights and biases, layer by layer),
``u_min, u_max, y_min, y_max`` (the ``mapminmax`` ranges, units of u and y) and ``metadata``::

    {"format_version": 1, "kind": "lab.mlp",
     "architecture": {"layer_sizes": [3, 20, 20, 3], "activation": "tanh", "output": "linear"},
     "normalisation": {"method": "mapminmax", "range": [-1, 1]},
     "units": {...}, "training": {...}, "code_version": "...", "created": "..."}

``training`` is whatever the trainer recorded (algorithm, epochs, stop reason, seed, split
sizes, errors, SHA-256 of the training data, ...). Files are written atomically (temporary
file + rename) and read with ``allow_pickle=False``. Anything wrong with a file -- missing,
truncated, corrupt, a newer format, a missing array, inconsistent shapes -- raises
:class:`ModelFileError` naming the file and the problem.
"""

from __future__ import annotations

import datetime as _dt
import json
import zipfile
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_open, json_default

FORMAT_VERSION = 1
KIND = "lab.mlp"


class ModelFileError(InputError):
    """A model file is missing, corrupt, truncated, inconsistent or from a newer format."""


def model_arrays(model) -> dict[str, np.ndarray]:
    """The arrays of one network's ``.npz`` (``metadata`` JSON included), as :func:`save_model`
    writes them; a composite model file (:mod:`lab.learn.residual`) stores them under a prefix.

    Parameters
    ----------
    model : MLP
        The network.

    Returns
    -------
    dict of str to numpy.ndarray
        ``metadata`` (JSON text), ``u_min``, ``u_max`` (n_u,) rad, ``y_min``, ``y_max``
        (n_y,) m, and ``W{l}``, ``b{l}`` per layer.
    """
    from lab.files import code_version

    meta = {
        "format_version": FORMAT_VERSION,
        "kind": KIND,
        "architecture": {"layer_sizes": list(model.layer_sizes), "activation": model.activation, "output": "linear"},
        "normalisation": {"method": "mapminmax", "range": [-1, 1]},
        **{k: v for k, v in model.metadata.items() if k not in ("format_version", "kind", "architecture")},
        "code_version": code_version(),
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }
    arrays = {
        "metadata": np.array(json.dumps(meta, default=json_default, allow_nan=False)),
        "u_min": model.u_min,
        "u_max": model.u_max,
        "y_min": model.y_min,
        "y_max": model.y_max,
    }
    for l, (w, b) in enumerate(zip(model.weights, model.biases)):
        arrays[f"W{l}"], arrays[f"b{l}"] = w, b
    return arrays


def save_model(model, path: str | Path) -> Path:
    """Write ``model`` to ``path`` (``.npz``) atomically; returns the path.

    Parameters
    ----------
    model : MLP
        The network.
    path : str or Path
        The model file.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    with atomic_open(path, "wb") as fh:
        np.savez(fh, **model_arrays(model))
    return path


def file_metadata(path: str | Path, arrays: dict | None = None) -> dict:
    """The ``metadata`` JSON object of a model file (any kind), checked for a readable
    ``format_version``; raises :class:`ModelFileError` naming the file and the problem.

    Parameters
    ----------
    path : str or Path
        The model file.
    arrays : dict, optional
        Its arrays, when already read.

    Returns
    -------
    dict
        The metadata (``kind``, ``format_version``, the training record, ...).
    """
    path = Path(path)
    if arrays is None:
        if not path.is_file():
            raise ModelFileError(f"model file not found: {path}")
        arrays = _read_arrays(path)
    raw = _need(arrays, "metadata", path)
    try:
        meta = json.loads(str(raw[()]))
    except (json.JSONDecodeError, TypeError, ValueError, IndexError) as err:
        raise ModelFileError(f"{path}: corrupt metadata JSON ({err})") from None
    if not isinstance(meta, dict):
        raise ModelFileError(f"{path}: metadata is not a JSON object")
    version = meta.get("format_version")
    if not isinstance(version, int) or isinstance(version, bool):
        raise ModelFileError(f"{path}: metadata has no integer format_version (got {version!r})")
    if version > FORMAT_VERSION:
        raise ModelFileError(
            f"{path}: format_version {version} is newer than this code reads ({FORMAT_VERSION}); update the package"
        )
    return meta


def _read_arrays(path: Path) -> dict[str, np.ndarray]:
    with open(path, "rb") as fh:
        if fh.read(4) != b"PK\x03\x04":
            raise ModelFileError(f"{path}: not an .npz (zip) archive; corrupt or truncated model file")
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}
    except ValueError as err:
        if "pickle" in str(err).lower():
            raise ModelFileError(f"{path}: holds pickled objects, which are never loaded") from None
        raise ModelFileError(f"{path}: corrupt or truncated model file ({err})") from None
    except (zipfile.BadZipFile, OSError, EOFError, KeyError) as err:
        raise ModelFileError(f"{path}: corrupt or truncated model file ({type(err).__name__}: {err})") from None
    except Exception as err:  # zlib.error, struct.error ...: any other reading failure
        raise ModelFileError(f"{path}: unreadable model file ({type(err).__name__}: {err})") from None


def _need(arrays: dict, key: str, path: Path) -> np.ndarray:
    if key not in arrays:
        raise ModelFileError(f"{path}: missing array {key!r} (truncated or not a lab model file)")
    return arrays[key]


def read_model(path: str | Path, activations: tuple[str, ...], prefix: str = "") -> dict:
    """Read and check a model file written by :func:`save_model`: the keyword arguments of
    :class:`lab.learn.mlp.MLP` (``weights``, ``biases``, ``activation``, ``metadata``,
    ``u_min``, ``u_max``, ``y_min``, ``y_max``). ``activations`` are the names the caller
    can build; ``prefix`` selects one network of a composite file (``"base."``).
    Raises :class:`ModelFileError` naming the file and the problem.
    (:func:`lab.learn.mlp.load_model` builds the network; this module never imports it.)

    Parameters
    ----------
    path : str or Path
        The model file.
    activations : tuple of str
        The activation names the caller can build.
    prefix : str
        The network's prefix in a composite file (``""`` for a plain one).

    Returns
    -------
    dict
        The keyword arguments of :class:`lab.learn.mlp.MLP`.
    """
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model file not found: {path}")
    arrays = _read_arrays(path)
    if prefix:
        arrays = {k[len(prefix) :]: v for k, v in arrays.items() if k.startswith(prefix)}
    meta = file_metadata(path, arrays)
    if meta.get("kind") != KIND:
        raise ModelFileError(f"{path}: kind {meta.get('kind')!r} is not {KIND!r}")
    arch = meta.get("architecture")
    if not isinstance(arch, dict) or "layer_sizes" not in arch or "activation" not in arch:
        raise ModelFileError(f"{path}: metadata lacks architecture.layer_sizes / architecture.activation")
    sizes, activation = arch["layer_sizes"], arch["activation"]
    if (
        not isinstance(sizes, list)
        or len(sizes) < 2
        or not all(isinstance(s, int) and not isinstance(s, bool) and s > 0 for s in sizes)
    ):
        raise ModelFileError(f"{path}: bad layer_sizes {sizes!r}")
    if activation not in activations:
        raise ModelFileError(f"{path}: unknown activation {activation!r} (known: {activations})")
    weights, biases = [], []
    for l in range(len(sizes) - 1):
        w, b = _need(arrays, f"W{l}", path), _need(arrays, f"b{l}", path)
        if w.shape != (sizes[l + 1], sizes[l]) or b.shape != (sizes[l + 1],):
            raise ModelFileError(
                f"{path}: layer {l} has W{w.shape} b{b.shape}, but layer_sizes {sizes} "
                f"needs W({sizes[l + 1]}, {sizes[l]}) b({sizes[l + 1]},)"
            )
        weights.append(w)
        biases.append(b)
    ranges = {}
    for key, n in (("u_min", sizes[0]), ("u_max", sizes[0]), ("y_min", sizes[-1]), ("y_max", sizes[-1])):
        ranges[key] = _need(arrays, key, path)
        if ranges[key].shape != (n,):
            raise ModelFileError(f"{path}: {key} has shape {ranges[key].shape}, expected ({n},)")
    for key, arr in [
        *ranges.items(),
        *((f"W{l}", w) for l, w in enumerate(weights)),
        *((f"b{l}", b) for l, b in enumerate(biases)),
    ]:
        if arr.dtype.kind != "f" or not np.all(np.isfinite(arr)):
            raise ModelFileError(f"{path}: array {key!r} is not finite floating point")
    keep = {k: v for k, v in meta.items() if k not in ("format_version", "kind", "architecture")}
    return {"weights": weights, "biases": biases, "activation": activation, "metadata": keep, **ranges}
