"""Table I of the paper: mean distance from target (cm) per condition and trajectory.

``figures/table1.csv`` (machine-readable) and ``figures/table1.md`` (for reading) hold one
row per *condition* -- "Real Data + Real Robot", "Sim Data + Real Robot", "Sim Data + Sim
Robot" as in the paper, plus our "Soft IK + Sim Robot" reference -- with our mean errors
next to the paper's values. Rows are keyed by condition, and :func:`update_table1`
read-merges-writes: a notebook that measures some conditions replaces only those rows and
keeps the others, so the simulated and the physical-rig rows can be produced by
different runs into the same files. Each write is atomic, and the read-merge-write runs
under an exclusive file lock, so concurrent updaters do not lose each other's rows.

CSV columns: ``condition``, ``circle_cm``, ``square_cm``, ``rose_cm`` (ours; empty where
not measured), ``paper_circle_cm``, ``paper_square_cm``, ``paper_rose_cm``, ``n_points``,
``source`` (what produced the row), ``updated`` (UTC date).
"""

from __future__ import annotations

import contextlib
import csv
import datetime as _dt
import io
import math
from pathlib import Path

from filelock import FileLock

from lab.errors import InputError
from lab.files import atomic_write_text, remove_and_release

SHAPES = ("circle", "square", "rose")
#: Table I of the paper, cm.
PAPER_CM = {
    "Real Data + Real Robot": {"circle": 0.15, "square": 0.14, "rose": 0.22},
    "Sim Data + Real Robot": {"circle": 0.68, "square": 0.62, "rose": 0.92},
    "Sim Data + Sim Robot": {"circle": 0.05, "square": 0.06, "rose": 0.04},
}
#: Row order: the paper's, then ours.
CONDITIONS = (*PAPER_CM, "Soft IK + Sim Robot")
COLUMNS = (
    "condition",
    *(f"{s}_cm" for s in SHAPES),
    *(f"paper_{s}_cm" for s in SHAPES),
    "n_points",
    "source",
    "updated",
)


class Table1Error(InputError):
    """A table file that cannot be read, or a row that cannot be written."""


def _cell(value) -> str:
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) else repr(float(value))


def read_table1(csv_path: str | Path) -> dict[str, dict]:
    """Rows of an existing table by condition ({} if the file does not exist)."""
    path = Path(csv_path)
    if not path.exists():
        return {}
    rows = list(csv.DictReader(io.StringIO(path.read_text())))
    if rows and set(rows[0]) != set(COLUMNS):
        raise Table1Error(f"{path}: columns {list(rows[0])} are not Table I's {list(COLUMNS)}")
    return {r["condition"]: r for r in rows}


def update_table1(
    results_cm: dict[str, dict[str, float]],
    csv_path: str | Path,
    md_path: str | Path,
    *,
    source: str,
    n_points: dict[str, int] | None = None,
) -> dict[str, dict]:
    """Set the rows of the conditions in ``results_cm``, keep every other row, rewrite both files.

    Raises :class:`Table1Error` for unknown trajectories, bad errors or a file that is not Table I's.

    Parameters
    ----------
    results_cm : dict
        ``{condition: {shape: mean error (cm)}}``, any subset of :data:`SHAPES`.
    csv_path, md_path : str or Path
        The table as CSV (:data:`COLUMNS`) and as Markdown beside the paper's numbers.
    source : str
        What produced the rows (e.g. the notebook).
    n_points : dict, optional
        ``{shape: N}`` targets per trajectory, recorded.

    Returns
    -------
    dict
        Every row of the table by condition (str values, errors in cm).
    """
    for cond, row in results_cm.items():
        unknown = set(row) - set(SHAPES)
        if unknown:
            raise Table1Error(f"{cond}: unknown trajectories {sorted(unknown)}; Table I has {SHAPES}")
        bad = {s: v for s, v in row.items() if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0)}
        if bad:
            raise Table1Error(f"{cond}: mean errors must be finite, non-negative numbers (cm), got {bad}")
    csv_path, md_path = Path(csv_path), Path(md_path)
    csv_path.parent.mkdir(parents=True, exist_ok=True)
    with _locked(csv_path):
        rows = read_table1(csv_path)
        today = _dt.datetime.now(_dt.UTC).date().isoformat()
        points = ";".join(f"{s}={n}" for s, n in (n_points or {}).items())
        for cond, values in results_cm.items():
            paper = PAPER_CM.get(cond, {})
            rows[cond] = {
                "condition": cond,
                **{f"{s}_cm": _cell(values.get(s)) for s in SHAPES},
                **{f"paper_{s}_cm": _cell(paper.get(s)) for s in SHAPES},
                "n_points": points,
                "source": source,
                "updated": today,
            }
        order = [c for c in CONDITIONS if c in rows] + sorted(c for c in rows if c not in CONDITIONS)
        buf = io.StringIO()
        writer = csv.DictWriter(buf, COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows[c] for c in order)
        atomic_write_text(csv_path, buf.getvalue())
        atomic_write_text(md_path, render_markdown([rows[c] for c in order]))
    return rows


def render_markdown(rows: list[dict]) -> str:
    """Markdown table: ours and the paper's side by side per trajectory (cm, 3 decimals)."""

    def fmt(v):
        return f"{float(v):.3f}" if v not in ("", None) else "–"

    head = ["condition"] + [f"{s} ({who})" for s in SHAPES for who in ("ours", "paper")]
    lines = [
        "# Table I: mean distance from target in cm for trajectory following",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for r in rows:
        cells = [r["condition"]] + [fmt(r[f"{p}{s}_cm"]) for s in SHAPES for p in ("", "paper_")]
        lines.append("| " + " | ".join(cells) + " |")
    lines += [
        "",
        "Ours: every 'Real Robot' is an **emulated as-built robot** (the `twin` rig: the FEM with "
        "fabrication defects, lag, play and motion-capture noise), not the paper's hardware; "
        "Table I over a family of such robots is `table1_family.md` (chapter 05).",
        "",
        "Sources: "
        + "; ".join(f"{r['condition']}: {r['source']} ({r['updated']}, points {r['n_points'] or '?'})" for r in rows),
        "",
    ]
    return "\n".join(lines)


@contextlib.contextmanager
def _locked(csv_path: Path):
    """Exclusive lock for updating ``csv_path``: the hidden file ``.NAME.lock`` beside it, so
    writers on different machines sharing the file system are serialised too; it is removed
    when the update ends (:func:`lab.files.remove_and_release`)."""
    # filelock: portable (fcntl does not exist on Windows)
    lock = FileLock(csv_path.parent / f".{csv_path.name}.lock")
    lock.acquire()
    try:
        yield
    finally:
        remove_and_release(lock)
