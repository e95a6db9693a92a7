"""What ``python -m lab import-data`` reads from someone else's measurement files.

Measurements of a robot this project did not capture -- a motion-capture export, a lab's
published data set -- arrive as CSV files whose columns have their own names and units.
:class:`ImportSpec` is the one setting that says how to read them: which columns are the
motor inputs (``--u``, in order: they become ``u0..u{m-1}``), which the measured position
(``--y``: the tip's x, y, z for a lab dataset; the library takes any number), the units
(``--u-unit``: a unit of :data:`U_UNITS` -- ``rad``, ``N`` for tensions, ``Pa``, ``kPa``,
``bar`` for pressures, ``mL`` for volumes -- is converted to SI (rad, N, Pa, m^3) and its
values checked for plausibility (:mod:`lab.data.plausibility`, as are the positions); any
other text is kept in the sidecar as it is (the default, ``rad``, is named in the command's
summary); ``--y-unit`` m, mm or cm, converted to metres), the robot the data are from (``--robot``: then the unit
must be of its inputs' kind, and the markers beyond the tip are its markers), the names of
the markers whose x, y, z follow the tip's in ``--y`` (``--markers``), where measurement
sequences restart (``--group``), how to pair input rows with
observation rows (``--id``), whether bad rows are an error or dropped and counted
(``--drop-bad-rows``), and the provenance kept with the data (``--licence``, ``--source``,
``--name``). The spec checks the column lists when it is built (a name given twice is an
error before any file is opened); :mod:`lab.data.importing` does the reading.
"""

from __future__ import annotations

from dataclasses import dataclass

from lab.specs import Spec, option

__all__ = ["ImportSpec", "Y_UNITS", "U_UNITS", "column_names", "markers_of_columns"]

#: Position units ``--y-unit`` accepts, with their factor to metres.
Y_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}
#: Input units ``--u-unit`` converts: unit -> (its SI unit, factor to it). Other text is kept as is.
U_UNITS = {
    "rad": ("rad", 1.0),
    "N": ("N", 1.0),
    "Pa": ("Pa", 1.0),
    "kPa": ("Pa", 1e3),
    "bar": ("Pa", 1e5),
    "mL": ("m^3", 1e-6),
}
#: What each SI input unit measures, for messages.
KINDS = {"rad": "an angle", "N": "a tension", "Pa": "a pressure", "m^3": "a volume"}


def markers_of_columns(names) -> tuple[str, ...] | None:
    """The marker names of position columns written in a dataset's convention: ``x, y, z``
    (or any first triple: the tip), then ``NAME_x, NAME_y, NAME_z`` per marker; None otherwise.

    Parameters
    ----------
    names : sequence of str
        The position columns (3K).

    Returns
    -------
    tuple of str or None
        ``("tip", NAME, ...)``, or None when the columns after the tip's do not follow the convention.
    """
    names = list(names)
    if len(names) % 3:
        return None
    out = ["tip"]
    for k in range(3, len(names), 3):
        stem = names[k][:-2] if names[k].endswith("_x") else ""
        if not stem or names[k : k + 3] != [f"{stem}_{a}" for a in "xyz"] or stem in out:
            return None
        out.append(stem)
    return tuple(out)


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
        The tip's x, y, z columns, then each further marker's (3K).
    markers : tuple of str or None
        The names of the markers after the tip, in ``y``'s order (default: the robot's, or
        the column names' ``NAME_x``).
    robot : str or None
        The robot the data are from (a shipped name or a TOML path).
    u_unit : str
        The inputs' unit: one of :data:`U_UNITS` (converted to SI), or free text kept in the
        sidecar (e.g. effort, mm); a comma-separated list gives one unit of U_UNITS per input.
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
        "rad",
        help="the inputs' unit: rad, N (tensions), Pa, kPa, bar (pressures, to Pa) or mL (volumes, to m^3), "
        "converted to SI, or one per input, comma-separated; other text (e.g. effort) is kept in the sidecar as is",
        check=_text,
    )
    markers: tuple[str, ...] | None = option(
        help="the names of the markers whose x,y,z columns follow the tip's in --y, comma-separated "
        "(default: --robot's markers, or NAME from columns NAME_x,NAME_y,NAME_z)",
        type=column_names,
        check=_names,
    )
    robot: str | None = option(
        help="the robot the data are from (shipped name or TOML): the inputs' unit must be of its inputs' kind "
        "and their number its inputs'",
        check=_text,
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
        units = column_names(self.u_unit)
        if len(units) > 1:
            bad = [u for u in units if u not in U_UNITS]
            if bad or len(units) != len(self.u):
                raise self.field_error(
                    f"ImportSpec.u_unit {self.u_unit!r}: a list gives one unit of {', '.join(U_UNITS)} per input "
                    f"column ({len(self.u)})" + (f", not {bad[0]!r}" if bad else f", got {len(units)}"),
                    "u_unit",
                )
        if self.markers is not None and len(self.markers) != len(self.y) // 3 - 1:
            raise self.field_error(
                f"ImportSpec.markers names {len(self.markers)} marker(s) but ImportSpec.y has "
                f"{len(self.y) // 3 - 1} triple(s) after the tip's",
                "markers",
                "y",
            )
        if self.id is not None and self.id in (*self.u, *self.y):
            raise self.field_error(
                f"ImportSpec.id {self.id!r} is also given in ImportSpec.u or ImportSpec.y: the ID column pairs "
                "rows, it is no data"
            )

    @property
    def u_units(self) -> tuple[str, ...] | None:
        """Each input's unit as given (one per ``u`` column) when ``u_unit`` names units of
        :data:`U_UNITS`; None for free text."""
        units = column_names(self.u_unit)
        if len(units) == 1:
            return units * len(self.u) if units[0] in U_UNITS else None
        return units

    @property
    def y_scale(self) -> float:
        """Metres per ``--y-unit``."""
        return Y_UNITS[self.y_unit]
