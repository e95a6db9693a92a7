"""Flags from specs: the command line's only way to declare a setting that a stage takes.

:func:`add_spec_flags` adds one flag per :func:`lab.specs.option` field of a spec class: its
spelling is ``--field-name`` unless :data:`.flag_names.SPELLING` says otherwise, and its
argparse keywords follow from the field's Python type (``bool`` -> a switch, ``tuple[int,
...]`` -> one or more integers, ``tuple[int, int]`` -> two, ``float | None`` -> a float) and
its declared choices. :func:`spec_from_args` turns the parsed arguments back into the spec,
which validates itself. A flag left unset stays ``None`` in the namespace, so a command can
tell "not given" from the default and refuse a flag its mode does not use
(:func:`refuse_unused`). :func:`flag_name` writes the flag for a spec's ``Class.field``, so
that a :class:`lab.errors.FieldError` reads as the flags the user typed.
"""

from __future__ import annotations

import dataclasses
import functools
import re
import types
import typing

from lab.cli.flag_names import SPELLING, TYPED, WORDS
from lab.errors import InputError
from lab.specs import meta

__all__ = [
    "add_spec_flags",
    "spec_from_args",
    "refuse_unused",
    "given",
    "flag_name",
    "flag_label",
    "flag_text",
    "flag_dest",
]

#: ``"Class.field"`` -> its flag, for every field a command has declared a flag for.
_DECLARED: dict[str, str] = {}


def _cli_fields(spec_cls, only=None, exclude=()):
    for f in dataclasses.fields(spec_cls):
        m = meta(f)
        if m is None or not m["cli"] or f.name in exclude or (only is not None and f.name not in only):
            continue
        yield f, m


@functools.cache
def _hints(spec_cls) -> dict:
    return typing.get_type_hints(spec_cls)


def _flag(spec_cls, f) -> str:
    return SPELLING.get(f"{spec_cls.__name__}.{f.name}", {}).get("flag") or "--" + f.name.replace("_", "-")


def _argparse_keywords(spec_cls, f, m) -> dict:
    """argparse's keywords for field ``f`` from its Python type, choices and spelling."""
    hint = _hints(spec_cls).get(f.name, object)
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        hint = next(a for a in typing.get_args(hint) if a is not type(None))
    if hint is bool:
        return {"action": "store_false" if f.default is True else "store_true"}
    kwargs, element = {}, hint
    if typing.get_origin(hint) is tuple:
        args = typing.get_args(hint)
        element = args[0] if args else str
        if m["type"] in (None, int, float, str):  # else a parser of the whole text
            kwargs["nargs"] = len(args) if Ellipsis not in args else "+"
    converter = m["type"] or (element if element in (int, float) else None)
    if converter is not None:
        kwargs["type"] = converter
    if m["choices"] is not None:
        kwargs["choices"] = m["choices"]
    spelled = SPELLING.get(f"{spec_cls.__name__}.{f.name}", {})
    kwargs.update({k: v for k, v in spelled.items() if k != "flag"})
    return kwargs


def add_spec_flags(parser, spec_cls, *, only=None, exclude=(), help: dict | None = None, default_words=None, base=None):
    """Add ``spec_cls``'s flags to ``parser``.

    Parameters
    ----------
    parser : argparse.ArgumentParser or argument group
        Where the flags go.
    spec_cls : type
        A :class:`lab.specs.Spec` dataclass.
    only, exclude : iterable of str, optional
        Field names to keep or drop.
    help : dict, optional
        Per-field help overrides.
    default_words : dict, optional
        Per field, how the help names the default (e.g. "the description's").
    base : Spec, optional
        An instance whose values are the command's defaults (else the spec's defaults; pass
        the same ``base`` to :func:`spec_from_args`).

    Returns
    -------
    object
        ``parser``.
    """
    help = help or {}
    default_words = default_words or {}
    for f, m in _cli_fields(spec_cls, only, exclude):
        text = help.get(f.name, m["help"])
        default = f.default if base is None else getattr(base, f.name)
        kwargs = _argparse_keywords(spec_cls, f, m)
        if f.name in default_words:
            text += f" (default: {default_words[f.name]})"
        elif default is not None and default is not dataclasses.MISSING and "action" not in kwargs:
            text += f" (default: {' '.join(map(str, default)) if isinstance(default, tuple) else default})"
        kwargs.update(dest=f.name, default=None, help=text)
        if m.get("required"):
            kwargs["required"] = True
        flag = _flag(spec_cls, f)
        _DECLARED[f"{spec_cls.__name__}.{f.name}"] = flag
        parser.add_argument(flag, **kwargs)
    return parser


def flag_name(name: str) -> str:
    """The flag of a spec field, as an error written for the command line names it.

    Parameters
    ----------
    name : str
        ``"Class.field"``, as a :class:`lab.errors.FieldError` names it.

    Returns
    -------
    str
        The flag (``--period-s``); ``name`` itself for a field no command has a flag for.
    """
    return _DECLARED.get(name) or TYPED.get(name) or name


def flag_label(name: str) -> str:
    """How an error about a setting's own value names it: its flag, and the field's name
    too where the flag spells it otherwise (``--split (ratios)``).

    Parameters
    ----------
    name : str
        ``"Class.field"``.

    Returns
    -------
    str
        The label; ``name`` itself for a field no command has a flag for.
    """
    flag, field = flag_name(name), name.partition(".")[2]
    return f"{flag} ({field})" if flag.startswith("--") and flag != "--" + field.replace("_", "-") else flag


def flag_text(text: str) -> str:
    """``text`` with each ``Class.field`` a command has a flag for written as that flag, and a
    run's arguments in the stage's words as their flags (:data:`.flag_names.WORDS`).

    Parameters
    ----------
    text : str
        A stage's words naming settings as ``Class.field``.

    Returns
    -------
    str
        The same words naming flags (``TrackSpec.model`` -> ``--model``).
    """
    for words, flag_words in WORDS.items():
        text = text.replace(words, flag_words)
    return re.sub(r"(?<![\w.])[A-Z]\w*\.[a-z_]\w*", lambda m: flag_name(m.group()), text)


def flag_dest(name: str) -> str:
    """The namespace name of a setting's flag.

    Parameters
    ----------
    name : str
        ``"Class.field"``.

    Returns
    -------
    str
        ``args``' attribute the flag sets (``TrackSpec.stream`` -> ``period_s``).
    """
    flag = flag_name(name)
    return flag[2:].replace("-", "_") if flag.startswith("--") else name.partition(".")[2]


def spec_from_args(spec_cls, args, base=None, **extra):
    """The spec built from the flags ``args`` holds.

    Parameters
    ----------
    spec_cls : type
        The spec class whose flags :func:`add_spec_flags` added.
    args : argparse.Namespace
        The parsed arguments; unset flags take the spec's defaults (or ``base``'s values).
    base : Spec, optional
        The command's defaults.
    **extra
        Fields given directly.

    Returns
    -------
    Spec
        The validated spec; a bad value raises :class:`lab.errors.FieldError`.
    """
    values = {}
    for f, m in _cli_fields(spec_cls):
        v = getattr(args, f.name, None)
        if v is not None and not (v is False and _argparse_keywords(spec_cls, f, m).get("action") == "store_true"):
            values[f.name] = tuple(v) if isinstance(v, list) else v
    values.update(extra)
    return spec_cls(**values) if base is None else dataclasses.replace(base, **values)


def given(args, *dests: str) -> list[str]:
    """The flags among ``dests`` that the user set.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments.
    *dests : str
        Namespace names.

    Returns
    -------
    list of str
        The set ones, as ``--flag`` words.
    """
    out = []
    for d in dests:
        v = getattr(args, d, None)
        if v is not None and v is not False:
            out.append("--" + d.replace("_", "-"))
    return out


def refuse_unused(args, dests, why: str) -> None:
    """Refuse (InputError) any of ``dests`` the user set: ``why`` says which mode ignores them.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments.
    dests : iterable of str
        Namespace names of the flags the mode does not use.
    why : str
        The end of the message, e.g. ``"in a streamed run"``.

    Returns
    -------
    None
    """
    used = given(args, *dests)
    if used:
        raise InputError(f"{', '.join(used)} {'is' if len(used) == 1 else 'are'} not used {why}")
