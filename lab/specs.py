"""Typed settings: the frozen dataclasses that cross every stage boundary.

A stage takes its settings as one small frozen dataclass (a *spec*), never as a loose bag
of keyword arguments or an ``argparse.Namespace``. Each field is declared with
:func:`option`, which carries what the stage knows about the setting -- its help, its unit,
how a text value becomes it (``type``), its allowed values and a check -- in the stage's own
words: no flag spellings or argparse vocabulary. :meth:`Spec.__post_init__` runs every
field's check and raises :class:`lab.errors.FieldError` naming the field ``Class.field``
(``TrackSpec.period_s must be finite and > 0, got -1``); a rule relating several fields is
written once, in the spec's ``__post_init__``, and raises a FieldError naming them all
(:meth:`Spec.field_error`). The command line (:mod:`lab.cli.flags`) derives each flag from
the field's name and Python type and writes the flag the user typed in an error's place.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

from lab.errors import FieldError

__all__ = ["Spec", "option", "finite", "positive", "non_negative", "positive_int", "non_negative_int", "at_most"]

_KEY = "lab.option"


def option(
    default: Any = None,
    *,
    help: str,
    type: Callable | None = None,
    check: Callable[[Any], str | None] | None = None,
    unit: str = "",
    choices=None,
    required: bool = False,
    cli: bool = True,
):
    """A spec field with what a user needs to set it.

    Parameters
    ----------
    default : object
        The field's default (None: not set).
    help : str
        What the setting means, in the stage's words.
    type : callable, optional
        How one text value becomes the field's value (or each element of a tuple field);
        default: the field's annotated type (``int``, ``float``, ``str``, ...).
    check : callable, optional
        ``check(value) -> None | problem``, run on every value but None.
    unit : str
        The value's unit (``"s"``, ``"m"``, ``"mm"``, ``"Hz"``, ``"N"``, ``"rad"``), written
        after the value in an error message; empty for a count or a word.
    choices : iterable, optional
        The allowed values.
    required : bool
        Whether None is refused.
    cli : bool
        False for a setting only a Python caller sets (the command line has no flag for it).

    Returns
    -------
    dataclasses.Field
        The field, its declaration kept in its metadata (:func:`meta`).
    """
    declared = {
        "help": help,
        "type": type,
        "check": check,
        "unit": unit,
        "choices": tuple(choices) if choices is not None else None,
        "required": required,
        "cli": cli,
    }
    return dataclasses.field(default=default, metadata={_KEY: declared})


def meta(f: dataclasses.Field) -> dict | None:
    """The :func:`option` declaration of a dataclass field.

    Parameters
    ----------
    f : dataclasses.Field
        A field of a spec class.

    Returns
    -------
    dict or None
        The declaration (help, type, check, unit, choices, required, cli); None for a plain field.
    """
    return f.metadata.get(_KEY)


def _got(value, unit: str) -> str:
    return f"got {value!r}" + (f" {unit}" if unit else "")


class Spec:
    """Mixin for frozen dataclasses whose fields are :func:`option` declarations."""

    def __post_init__(self):
        for f in dataclasses.fields(self):
            m = meta(f)
            if m is None:
                continue
            value = getattr(self, f.name)
            if value is None:
                if m.get("required"):
                    raise self.field_error(f"{self.name_of(f.name)} is required", f.name)
                continue
            if m["choices"] is not None and value not in m["choices"]:
                allowed = ", ".join(map(str, m["choices"]))
                raise self.field_error(
                    f"{self.name_of(f.name)} must be one of {allowed}, got {value!r}", f.name
                ).of_value()
            if m["check"] is not None:
                problem = m["check"](value)
                if problem:
                    message = f"{self.name_of(f.name)} {problem}, {_got(value, m['unit'])}"
                    raise self.field_error(message, f.name).of_value()

    @classmethod
    def name_of(cls, field: str) -> str:
        """How a message names one of this spec's fields.

        Parameters
        ----------
        field : str
            The field's name.

        Returns
        -------
        str
            ``"Class.field"`` (e.g. ``"TrackSpec.period_s"``).
        """
        return f"{cls.__name__}.{field}"

    @classmethod
    def field_error(cls, message: str, *fields: str) -> FieldError:
        """The error for a bad value of ``fields`` (a rule relating them, or one field's check).

        Parameters
        ----------
        message : str
            What is wrong, naming each field as :meth:`name_of` writes it.
        *fields : str
            The fields of this spec the message names (or ``"Other.field"`` of a nested spec).

        Returns
        -------
        FieldError
            To raise; it carries the spec and the fields, so the command line can name flags.
        """
        return FieldError(message, *(f if "." in f else cls.name_of(f) for f in fields))

    def replace(self, **changes):
        """A copy with ``changes``, validated again.

        Parameters
        ----------
        **changes
            New values of fields, by name.

        Returns
        -------
        Spec
            The copy.
        """
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """The fields as plain values (for result metadata).

        Returns
        -------
        dict
            Field name -> value.
        """
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


# --- checks: each returns None when the value is fine, else what is wrong -------------------


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def finite(v) -> str | None:
    """A check: a finite number. Returns None when ``v`` is fine, else the problem (str)."""
    return None if _is_number(v) and math.isfinite(v) else "must be a finite number"


def positive(v) -> str | None:
    """A check: a finite number > 0. Returns None when ``v`` is fine, else the problem (str)."""
    return None if _is_number(v) and math.isfinite(v) and v > 0 else "must be finite and > 0"


def non_negative(v) -> str | None:
    """A check: a finite number >= 0. Returns None when ``v`` is fine, else the problem (str)."""
    return None if _is_number(v) and math.isfinite(v) and v >= 0 else "must be finite and >= 0"


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def positive_int(v) -> str | None:
    """A check: an integer >= 1. Returns None when ``v`` is fine, else the problem (str)."""
    return None if _is_int(v) and v >= 1 else "must be a positive integer"


def non_negative_int(v) -> str | None:
    """A check: an integer >= 0. Returns None when ``v`` is fine, else the problem (str)."""
    return None if _is_int(v) and v >= 0 else "must be an integer >= 0"


def at_most(limit: float, base: Callable = finite, unit: str = "") -> Callable:
    """A check: ``base`` and at most ``limit`` (what the machine or hardware allows).

    Parameters
    ----------
    limit : float
        The largest value allowed, in ``unit``.
    base : callable
        The check the value must pass first.
    unit : str
        Written after the limit in the problem (e.g. ``" Hz"``).

    Returns
    -------
    callable
        The check: ``check(value) -> None | problem``.
    """

    def check(v):
        problem = base(v)
        if problem:
            return problem
        return None if v <= limit else f"must be at most {limit:g}{unit}"

    return check
