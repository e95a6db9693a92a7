"""What a forward model's outputs and inputs are: its markers and its input units.

A dataset's outputs are every observed point of the robot, the tip first: columns
``x, y, z`` for the tip, then ``NAME_x, NAME_y, NAME_z`` per marker, so a model fitted to
it predicts ``y`` (3K,) m for K markers. :func:`record_io` writes the marker names
(``outputs.markers``) and each input's unit (``units.inputs``: ``"rad"`` for a spool angle,
``"N"`` for a tension) into a model's metadata; :func:`output_markers` and
:func:`input_units` read them back, a model file written before these keys (none of them)
reading as the tip only and angles in rad. (The IK picks some markers' rows of ``y``
through :mod:`lab.control.markers`, which reads ``outputs.markers`` itself: the IK takes any
forward map and does not import this stage.)
"""

from __future__ import annotations

from collections.abc import Sequence

from lab.errors import InputError

__all__ = ["dataset_io", "input_units", "output_markers", "record_io"]


def _names(value) -> tuple[str, ...] | None:
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, str) and v for v in value):
        return tuple(value)
    return None


def dataset_io(meta: dict, n_u: int, n_y: int, where: str = "dataset") -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The marker names and input units of a dataset from its sidecar, checked against its widths.

    Parameters
    ----------
    meta : dict
        The sidecar (``markers``: the observed points, tip first; ``input_units`` or
        ``robot.input_units``: each input's unit, or ``robot.u_unit`` for every input).
        Missing keys: the tip only, rad.
    n_u : int
        The dataset's number of inputs.
    n_y : int
        The dataset's number of output columns (3 per marker).
    where : str
        How errors name the dataset.

    Returns
    -------
    markers : tuple of str
        The observed points, ``"tip"`` first, K = n_y / 3 of them.
    units : tuple of str
        The unit of each input (n_u of them).

    Raises
    ------
    InputError
        When the sidecar's markers do not match the output columns, or its units the inputs.
    """
    markers = _names(meta.get("markers"))
    if markers is None:
        if n_y % 3:
            raise InputError(f"{where}: {n_y} output columns are not 3 per marker (x, y, z)")
        markers = ("tip",) + tuple(f"marker{k}" for k in range(1, n_y // 3))
    if 3 * len(markers) != n_y:
        raise InputError(f"{where}: sidecar markers {list(markers)} need {3 * len(markers)} output columns, got {n_y}")
    robot = meta.get("robot") if isinstance(meta.get("robot"), dict) else {}
    single = robot.get("u_unit") if isinstance(robot.get("u_unit"), str) and robot.get("u_unit") else None
    units = (
        _names(meta.get("input_units"))
        or _names(robot.get("input_units"))
        or ((single,) * n_u if single else ("rad",) * n_u)
    )
    if len(units) != n_u:
        raise InputError(f"{where}: sidecar input_units {list(units)} name {len(units)} inputs, the data have {n_u}")
    return markers, units


def record_io(model, markers: Sequence[str], units: Sequence[str]) -> None:
    """Write a model's output markers and input units into its metadata.

    Parameters
    ----------
    model : object
        A fitted model with a ``metadata`` dict.
    markers : sequence of str
        Its output markers, the tip first (3 outputs each).
    units : sequence of str
        The unit of each input ("rad" or "N").

    Returns
    -------
    None
    """
    model.metadata["outputs"] = {"markers": list(markers)}
    units_meta = dict(model.metadata.get("units") or {})
    units_meta["inputs"] = list(units)
    if "u" in units_meta:  # the older single unit of every input
        units_meta["u"] = units[0] if len(set(units)) == 1 else "mixed"
    model.metadata["units"] = units_meta


def output_markers(model) -> tuple[str, ...]:
    """The markers a forward model predicts, the tip first; ``("tip",)`` for an older file.

    Parameters
    ----------
    model : object
        A model with a ``metadata`` dict (or None).

    Returns
    -------
    tuple of str
        The marker names, 3 outputs each.
    """
    meta = getattr(model, "metadata", None) or {}
    return _names((meta.get("outputs") or {}).get("markers")) or ("tip",)


def input_units(model, n_u: int) -> tuple[str, ...]:
    """The unit of each input of a model; ``"rad"`` each for an older file.

    Parameters
    ----------
    model : object
        A model with a ``metadata`` dict (or None).
    n_u : int
        Its number of inputs.

    Returns
    -------
    tuple of str
        ``"rad"`` or ``"N"`` per input (n_u of them).
    """
    meta = getattr(model, "metadata", None) or {}
    units = meta.get("units") if isinstance(meta.get("units"), dict) else {}
    found = _names(units.get("inputs"))
    return found if found is not None and len(found) == n_u else ("rad",) * n_u
