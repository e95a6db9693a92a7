"""The sampling flags that ``simulate`` and ``capture`` share: which commands to measure.

    --grid L | --sobol N | --lhs N | --design {random,sobol,maximin,lhs} --n N | --active N --batch B

The flags are :class:`lab.data.DesignSpec`'s fields (help, checks and meaning live there);
the five designs exclude each other. The command's own ``--seed`` seeds the design.
"""

from __future__ import annotations

from lab.cli.flags import add_spec_flags, spec_from_args
from lab.data.design_spec import DesignSpec

__all__ = ["add_design_flags", "design_from_args"]

#: The flags of which one picks the design (mutually exclusive).
_CHOICE = ("grid", "sobol", "lhs", "design", "active")


def add_design_flags(p) -> None:
    """Add the sampling flags to the parser ``p`` (its ``--seed`` is the command's own)."""
    add_spec_flags(p.add_mutually_exclusive_group(), DesignSpec, only=_CHOICE)
    add_spec_flags(p, DesignSpec, exclude=_CHOICE)


def design_from_args(args) -> DesignSpec:
    """The :class:`DesignSpec` of the parsed flags ``args`` (with ``args.seed``); a bad
    combination or count raises InputError before any file is touched."""
    return spec_from_args(DesignSpec, args, seed=args.seed)
