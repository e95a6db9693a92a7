"""What ``python -m lab import-data`` reads from someone else's measurement files.

Measurements of a robot this project did not capture -- a motion-capture export, a lab's
published data set -- arrive as CSV files whose columns have their own names and units.
:class:`ImportSpec` is the one setting that says how to read them: which columns are the
motor inputs (``--u``, in order: they become ``u0..u{m-1}``), which the measured position
(``--y``: the tip's x, y, z for a lab dataset; the library takes any number), the units
(``--u-unit`` is free text kept in the sidecar; ``--y-unit`` m, mm or cm, converted to
metres), where measurement sequences restart (``--group``), how to pair input rows with
observation rows (``--id``), whether bad rows are an error or dropped and counted
(``--drop-bad-rows``), and the provenance kept with the data (``--licence``, ``--source``,
``--name``). The spec checks the column lists when it is built (a name given twice is an
error before any file is opened); :mod:`lab.data.importing` does the reading.
"""

from __future__ import annotations

from dataclasses import dataclass

from lab.specs import Spec, option

__all__ = ["ImportSpec", "Y_UNITS", "column_names"]

#: Position units ``--y-unit`` accepts, with their factor to metres.
Y_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}


def column_names(text: str) -> tuple[str, ...]:
    """``"u1, u2,u3"`` -> ``("u1", "u2", "u3")``: a comma-separated list of column names."""
    return tuple(name.strip() for name in str(text).split(","))


def _names(v) -> str | None:
    if not isinstance(v, tuple) or not v or not all(isinstance(n, str) and n for n in v):
        return "must be comma-separated column names, none empty (e.g. u1,u2,u3)"
    twice = sorted({n for n in v if v.count(n) > 1})
    return f"names the column {twice[0]!r} twice" if twice else None


def _text(v) -> str | None:
    return None if isinstance(v, str) and v.strip() else "must be non-empty text"


@dataclass(frozen=True)
class ImportSpec(Spec):
    """How to read external measurement files into (u, y) rows; see the module docstring.

    Attributes
    ----------
    u : tuple of str
        The input columns, in order (they become u0, u1, ...).
    y : tuple of str
        The tip's x, y, z columns (exactly 3).
    u_unit : str
        The inputs' unit, free text kept in the sidecar (e.g. effort, mm, rad).
    y_unit : str
        The positions' unit (a key of ``Y_UNITS``); converted to metres.
    group : str or None
        A column whose value changes where a new measurement sequence starts.
    id : str or None
        With observation files: pair input and observation rows on this column.
    drop_bad_rows : bool
        Drop (and count) rows with a NaN, empty or non-numeric value instead of an error.
    licence, source : str or None
        The data's licence, and where the data come from; kept in the sidecar.
    name : str or None
        The robot's name in the sidecar (default: the output file's stem).
    """

    u: tuple[str, ...] | None = option(
        help="the input columns, comma-separated, in order (they become u0, u1, ...), e.g. u1,u2,u3,u4,u5,u6",
        type=column_names,
        check=_names,
        required=True,
    )
    y: tuple[str, ...] | None = option(
        help="the measured position columns, comma-separated: the tip's x,y,z (exactly 3 for a lab dataset), "
        "e.g. x3,y3,z3",
        type=column_names,
        check=_names,
        required=True,
    )
    u_unit: str = option(
        "rad", help="the inputs' unit, free text kept in the sidecar (e.g. effort, mm, rad)", check=_text
    )
    y_unit: str = option("m", help="the positions' unit; converted to metres", choices=tuple(Y_UNITS))
    group: str | None = option(
        help="a column whose value changes where a new measurement sequence starts (within a file)"
    )
    id: str | None = option(
        help="with --observations: pair input and observation rows on this column, which both files have "
        "(default: row by row)",
    )
    drop_bad_rows: bool = option(
        False,
        help="drop rows with a NaN, empty or non-numeric value and count them in the sidecar (default: an error)",
    )
    licence: str | None = option(help="the data's licence, kept in the sidecar", check=_text)
    source: str | None = option(
        help="where the data come from (repository, commit, paper), kept in the sidecar", check=_text
    )
    name: str | None = option(help="the robot's name in the sidecar (default: the --out file's stem)", check=_text)

    def __post_init__(self):
        super().__post_init__()
        both = [n for n in self.u if n in self.y]
        if both:
            raise self.field_error(
                f"the column {both[0]!r} is given in both ImportSpec.u and ImportSpec.y: each column is one thing"
            )
        if self.id is not None and self.id in (*self.u, *self.y):
            raise self.field_error(
                f"ImportSpec.id {self.id!r} is also given in ImportSpec.u or ImportSpec.y: the ID column pairs "
                "rows, it is no data"
            )

    @property
    def y_scale(self) -> float:
        """Metres per ``--y-unit``."""
        return Y_UNITS[self.y_unit]
