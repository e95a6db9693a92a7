"""Typed settings: the frozen dataclasses that cross every stage boundary.

A stage takes its settings as one small frozen dataclass (a *spec*), never as a loose bag
of keyword arguments or an ``argparse.Namespace``. Each field is declared with
:func:`option`, which carries what a user needs to set it -- the command-line flag, its
help, its type, a check -- so that flag help and validation live in one place: the spec.
:meth:`Spec.__post_init__` runs every field's check and raises :class:`InputError` naming
the flag (or the field, for a spec built in Python). The command line
(:mod:`lab.cli.flags`) builds its flags from these declarations and only turns arguments
into specs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

from lab.errors import InputError

__all__ = ["Spec", "option", "finite", "positive", "non_negative", "positive_int", "non_negative_int", "at_most"]

_KEY = "lab.option"


def option(
    default: Any = None,
    *,
    help: str,
    flag: str | None = None,
    type: Callable | None = None,
    check: Callable[[Any], str | None] | None = None,
    metavar: str | None = None,
    choices=None,
    action: str | None = None,
    cli: bool = True,
    nargs=None,
    required: bool = False,
):
    """A spec field with its flag. ``check(value) -> None | message`` is run on every value
    but ``None``; ``flag`` defaults to ``--field-name``; ``cli=False`` keeps it out of the flags.
    ``nargs``: as argparse's (the value is then a tuple); ``required``: None is refused."""
    meta = {
        "help": help,
        "flag": flag,
        "type": type,
        "check": check,
        "metavar": metavar,
        "choices": tuple(choices) if choices is not None else None,
        "action": action,
        "cli": cli,
        "nargs": nargs,
        "required": required,
    }
    return dataclasses.field(default=default, metadata={_KEY: meta})


def meta(f: dataclasses.Field) -> dict | None:
    """The :func:`option` declaration of a dataclass field, or None for a plain field."""
    return f.metadata.get(_KEY)


def flag_of(f: dataclasses.Field) -> str:
    m = meta(f) or {}
    return m.get("flag") or "--" + f.name.replace("_", "-")


def label_of(f: dataclasses.Field) -> str:
    """How an error names a field: its flag; the field's name too where the flag spells it
    differently (``--solver (method)``); only the name for a field without a flag."""
    m = meta(f) or {}
    if not m.get("cli", True):
        return f.name
    flag = flag_of(f)
    return flag if flag == "--" + f.name.replace("_", "-") else f"{flag} ({f.name})"


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
                    raise InputError(f"{flag_of(f)} is required")
                continue
            if m["choices"] is not None and value not in m["choices"]:
                raise InputError(f"{label_of(f)} must be one of {', '.join(map(str, m['choices']))}, got {value!r}")
            if m["check"] is not None:
                problem = m["check"](value)
                if problem:
                    raise InputError(f"{label_of(f)} {problem}, got {value!r}")

    def replace(self, **changes):
        """A copy with ``changes`` (validated again)."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """The fields as plain JSON-ready values (for result metadata)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


# --- checks: each returns None when the value is fine, else what is wrong -------------------


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def finite(v) -> str | None:
    return None if _is_number(v) and math.isfinite(v) else "must be a finite number"


def positive(v) -> str | None:
    return None if _is_number(v) and math.isfinite(v) and v > 0 else "must be finite and > 0"


def non_negative(v) -> str | None:
    return None if _is_number(v) and math.isfinite(v) and v >= 0 else "must be finite and >= 0"


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def positive_int(v) -> str | None:
    return None if _is_int(v) and v >= 1 else "must be a positive integer"


def non_negative_int(v) -> str | None:
    return None if _is_int(v) and v >= 0 else "must be an integer >= 0"


def at_most(limit: float, base: Callable = finite, unit: str = "") -> Callable:
    """A check: ``base`` and at most ``limit`` (what the machine or hardware allows)."""

    def check(v):
        problem = base(v)
        if problem:
            return problem
        return None if v <= limit else f"must be at most {limit:g}{unit}"

    return check
