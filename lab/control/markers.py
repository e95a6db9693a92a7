"""Which observed points the IK drives: the tip by default, any marker or set of markers on request.

A forward map of a robot with K markers predicts ``y`` (3K,) m, the tip's x, y, z first,
then each marker's, in the order of the robot's ``marker_names``. The IK's target is the
concatenation of the positions of the markers it drives (``IKConfig.markers``, the tip
alone by default: a (3,) target as ever). :func:`select_markers` gives the forward map the
solver works through: the map itself when it predicts exactly those markers, else a
:class:`MarkerForward` view of its rows (prediction, Jacobian, ensemble members and
spread).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lab.errors import InputError

__all__ = ["MarkerForward", "forward_markers", "marker_rows", "select_markers"]


def marker_rows(available: Sequence[str], wanted: Sequence[str], where: str = "the model") -> np.ndarray:
    """The output rows of some markers: 3 per marker, in ``wanted``'s order.

    Parameters
    ----------
    available : sequence of str
        The markers of the outputs, in order (3 rows each).
    wanted : sequence of str
        The markers to select (at least one, each once).
    where : str
        What has the outputs, for the error.

    Returns
    -------
    numpy.ndarray
        Row indices (3 len(wanted),) int.

    Raises
    ------
    InputError
        Naming an unknown or repeated marker, and the known ones.
    """
    available, wanted = list(available), list(wanted)
    if not wanted:
        raise InputError(f"markers: select at least one of {available}")
    unknown = [w for w in wanted if w not in available]
    if unknown:
        raise InputError(f"markers: {unknown} not among the markers of {where} {available}")
    if len(set(wanted)) != len(wanted):
        raise InputError(f"markers: each marker once, got {wanted}")
    return np.concatenate([3 * available.index(w) + np.arange(3) for w in wanted])


def _model_markers(forward) -> tuple[str, ...]:
    """``metadata["outputs"]["markers"]`` of a model (:func:`lab.learn.outputs.record_io`);
    the tip alone for a model without them."""
    meta = getattr(forward, "metadata", None) or {}
    names = (meta.get("outputs") or {}).get("markers") if isinstance(meta, dict) else None
    if isinstance(names, (list, tuple)) and names and all(isinstance(n, str) for n in names):
        return tuple(names)
    return ("tip",)


def forward_markers(forward) -> tuple[str, ...]:
    """The markers a forward map predicts, in order (3 outputs each).

    Parameters
    ----------
    forward : object
        A forward map: ``marker_names`` (the FEM's map), or a model whose metadata names
        its outputs (``outputs.markers``; the tip for an older file).

    Returns
    -------
    tuple of str
        The marker names.

    Raises
    ------
    InputError
        When the names do not match the map's number of outputs ``n_y``.
    """
    names = getattr(forward, "marker_names", None)
    names = tuple(names) if names is not None else _model_markers(forward)
    n_y = getattr(forward, "n_y", None)
    if n_y is not None and int(n_y) != 3 * len(names):
        raise InputError(
            f"the model predicts {n_y} outputs, but the targets have 3 columns (x, y, z) per marker and its "
            f"markers {list(names)} have {3 * len(names)}: the IK needs a model of the markers' positions"
        )
    return names


class MarkerForward:
    """The rows of some markers of a forward map, behind the same interface.

    Parameters
    ----------
    forward : object
        The forward map (``predict``, ``predict_and_jacobian``; optionally ``members``,
        ``predict_with_std``).
    rows : array_like of int
        Its output rows to keep (3 per selected marker).
    markers : tuple of str
        The selected markers' names.
    """

    def __init__(self, forward, rows, markers: tuple[str, ...]):
        self.forward, self.rows, self.marker_names = forward, np.asarray(rows, int), tuple(markers)
        self.has_jacobian = bool(getattr(forward, "has_jacobian", True))
        self.metadata = getattr(forward, "metadata", {})
        if hasattr(forward, "n_u"):
            self.n_u = forward.n_u
        self.n_y = len(self.rows)
        members = getattr(forward, "members", None)
        if members is not None:
            self.members = [MarkerForward(m, self.rows, self.marker_names) for m in members]
        if callable(getattr(forward, "predict_with_std", None)):
            self.predict_with_std = self._predict_with_std

    def predict(self, u_motor) -> np.ndarray:
        """The selected markers' positions for one or N commands.

        Parameters
        ----------
        u_motor : array_like
            Command(s) (m,) or (N, m), in the inputs' units.

        Returns
        -------
        numpy.ndarray
            Positions (3M,) or (N, 3M), m, for the M selected markers.
        """
        return np.asarray(self.forward.predict(u_motor), dtype=float)[..., self.rows]

    def predict_and_jacobian(self, u_motor) -> tuple[np.ndarray, np.ndarray]:
        """The selected markers' positions and their Jacobian at one command.

        Parameters
        ----------
        u_motor : array_like
            The command (m,).

        Returns
        -------
        y : numpy.ndarray
            Positions (3M,), m.
        J : numpy.ndarray
            Jacobian (3M, m), m per input unit.
        """
        y, J = self.forward.predict_and_jacobian(u_motor)
        return np.asarray(y, dtype=float)[self.rows], np.asarray(J, dtype=float)[self.rows]

    def _predict_with_std(self, u_motor, *args, **kwargs):
        mean, std = self.forward.predict_with_std(u_motor, *args, **kwargs)
        return np.asarray(mean, dtype=float)[..., self.rows], np.asarray(std, dtype=float)[..., self.rows]


def select_markers(forward, markers) -> object:
    """The forward map of the markers the IK drives.

    Parameters
    ----------
    forward : object
        The forward map of every marker (``n_y`` = 3K outputs).
    markers : tuple of str
        The markers to drive, in the target's order.

    Returns
    -------
    object
        ``forward`` itself when it predicts exactly ``markers`` in that order, else a
        :class:`MarkerForward` of their rows.

    Raises
    ------
    InputError
        Naming an unknown marker and the known ones.
    """
    names = forward_markers(forward)
    markers = tuple(markers)
    if markers == names:
        return forward
    return MarkerForward(forward, marker_rows(names, markers, "the forward map"), markers)
