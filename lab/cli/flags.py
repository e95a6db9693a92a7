"""Flags from specs: the command line's only way to declare a setting that a stage takes.

:func:`add_spec_flags` adds one flag per :func:`lab.specs.option` field of a spec class,
with the help, type and choices declared there; :func:`spec_from_args` turns the parsed
arguments back into the spec, which validates itself. A flag left unset stays ``None`` in
the namespace, so a command can tell "not given" from the default and refuse a flag its
mode does not use (:func:`refuse_unused`).
"""

from __future__ import annotations

import dataclasses

from lab.errors import InputError
from lab.specs import flag_of, meta

__all__ = ["add_spec_flags", "spec_from_args", "refuse_unused", "given"]


def _cli_fields(spec_cls, only=None, exclude=()):
    for f in dataclasses.fields(spec_cls):
        m = meta(f)
        if m is None or not m["cli"] or f.name in exclude or (only is not None and f.name not in only):
            continue
        yield f, m


def add_spec_flags(parser, spec_cls, *, only=None, exclude=(), help: dict | None = None, default_words=None, base=None):
    """Add ``spec_cls``'s flags to ``parser`` (an argparse parser or group); returns the group.

    ``only``/``exclude``: field names to keep or drop; ``help``: per-field help overrides.
    ``default_words``: per field, how the help names the default (e.g. "the description's").
    ``base``: an instance whose values are the command's defaults (else the spec's defaults;
    pass the same ``base`` to :func:`spec_from_args`).
    """
    help = help or {}
    default_words = default_words or {}
    for f, m in _cli_fields(spec_cls, only, exclude):
        text = help.get(f.name, m["help"])
        default = f.default if base is None else getattr(base, f.name)
        if f.name in default_words:
            text += f" (default: {default_words[f.name]})"
        elif default is not None and default is not dataclasses.MISSING and m["action"] is None:
            text += f" (default: {' '.join(map(str, default)) if isinstance(default, tuple) else default})"
        kwargs = {"dest": f.name, "default": None, "help": text}
        if m.get("required"):
            kwargs["required"] = True
        if m["action"] is not None:
            kwargs["action"] = m["action"]
        else:
            if m["type"] is not None:
                kwargs["type"] = m["type"]
            if m["choices"] is not None:
                kwargs["choices"] = m["choices"]
            if m["metavar"] is not None:
                kwargs["metavar"] = m["metavar"]
            if m.get("nargs") is not None:
                kwargs["nargs"] = m["nargs"]
        parser.add_argument(flag_of(f), **kwargs)
    return parser


def spec_from_args(spec_cls, args, base=None, **extra):
    """The spec built from the flags ``args`` holds (unset flags take the spec's defaults, or
    ``base``'s values), with ``extra`` fields given directly; an invalid value raises
    InputError naming its flag."""
    values = {}
    for f, m in _cli_fields(spec_cls):
        v = getattr(args, f.name, None)
        if v is not None and not (m["action"] == "store_true" and v is False):
            values[f.name] = tuple(v) if isinstance(v, list) else v
    values.update(extra)
    return spec_cls(**values) if base is None else dataclasses.replace(base, **values)


def given(args, *dests: str) -> list[str]:
    """The flags among ``dests`` (namespace names) that the user set, as ``--flag`` words."""
    out = []
    for d in dests:
        v = getattr(args, d, None)
        if v is not None and v is not False:
            out.append("--" + d.replace("_", "-"))
    return out


def refuse_unused(args, dests, why: str) -> None:
    """Refuse (InputError) any of ``dests`` the user set: ``why`` says which mode ignores them."""
    used = given(args, *dests)
    if used:
        raise InputError(f"{', '.join(used)} {'is' if len(used) == 1 else 'are'} not used {why}")
