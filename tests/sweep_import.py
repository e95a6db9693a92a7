"""Fault-sweep rows (tests/sweep.py format) for ``import-data``: bad files, columns, values, pairings.

Each case writes small CSV files into its directory: ``both.csv`` (inputs a,b and positions
x,y,z in one file, with a ``run`` column), ``in.csv`` / ``obs.csv`` (inputs and observations,
both with an ``ID`` column). Cell edits make the bad versions.
"""

import json
from pathlib import Path

import numpy as np
from filelock import FileLock
from sweep import Case

from lab.data import read_dataset

BOTH = "a,b,x,y,z,run\n1,2,10,20,30,r1\n3,4,11,21,31,r1\n5,6,12,22,32,r2\n"
IN = "ID,a,b\n0,1,2\n1,3,4\n2,5,6\n"
OBS = "ID,x,y,z\n0,10,20,30\n1,11,21,31\n2,12,22,32\n"
SINGLE = ["import-data", "{dir}/both.csv", "--u", "a,b", "--y", "x,y,z", "--y-unit", "mm"]
PAIR = ["import-data", "{dir}/in.csv", "--observations", "{dir}/obs.csv", *SINGLE[2:]]
OUT = ["--out", "{dir}/o.csv"]
NO_OUT = ("{dir}/o.csv", "{dir}/o.csv.json")
_locks: dict = {}


def files(**texts):
    """A setup writing ``both.csv``, ``in.csv``, ``obs.csv`` and the files named in ``texts``
    (``name_csv="..."`` -> ``name.csv``; bytes are written as they are)."""

    def setup(d: Path):
        for name, text in {"both_csv": BOTH, "in_csv": IN, "obs_csv": OBS, **texts}.items():
            p = d / name.replace("_csv", ".csv")
            p.write_bytes(text if isinstance(text, bytes) else text.encode())

    return setup


def cell(name, old, new):
    """``files()`` with ``old`` replaced by ``new`` (once) in file ``name``."""
    base = {"both.csv": BOTH, "in.csv": IN, "obs.csv": OBS}[name]
    assert old in base
    return files(**{name.replace(".csv", "_csv"): base.replace(old, new, 1)})


def sidecar(check):
    """An ``after`` check on the written dataset: ``check(u, y, meta)``."""

    def after(d: Path):
        check(*read_dataset(d / "o.csv"))

    return after


def _lock(d: Path):
    _locks["o"] = FileLock(str(d / "o.csv") + ".lock", timeout=0)
    _locks["o"].acquire()


def _release(d: Path):
    _locks.pop("o").release()


def _dropped(u, y, meta):
    assert len(u) == 1 and meta["row_groups"][0]["dropped"] == {"nan": 1, "non_numeric": 1, "unmatched_id": 0}


def _grouped(u, y, meta):
    assert meta["sequence_starts"] == [0, 2] and meta["robot"]["u_max"] == [5.0, 6.0]


def _row_order(u, y, meta):
    assert meta["row_groups"][0]["join"] == "row" and "phantom-ID rule" in meta["notes"][0]
    np.testing.assert_allclose(y[:, 0], [0.010, 0.011, 0.012])


def _mm(u, y, meta):
    np.testing.assert_allclose(y[0], [0.010, 0.020, 0.030])
    assert meta["import"]["y_unit_read"] == "mm" and meta["robot"]["y_unit"] == "m"


def _round_trip(d: Path):
    u0, y0, _ = read_dataset(d / "data.csv")
    u, y, meta = read_dataset(d / "o.csv")
    np.testing.assert_array_equal(u, u0)
    np.testing.assert_array_equal(y, y0)
    assert meta["robot"]["kind"] == "measured" and json.loads((d / "o.csv.json").read_text())["sequence_starts"] == [0]


IMPORT_CASES: list = [
    Case("import-single-file-ok", [*SINGLE, "--group", "run", *OUT], 0, setup=files(), after=sidecar(_grouped)),
    Case("import-pair-by-id-ok", [*PAIR, "--id", "ID", *OUT], 0, setup=files()),
    Case("import-shipped-dataset-round-trip",
         ["import-data", "{dir}/data.csv", "--u", "u0,u1,u2", "--y", "x,y,z", *OUT], 0, after=_round_trip),
    Case("import-y-in-mm", [*SINGLE, *OUT], 0, setup=files(), after=sidecar(_mm)),
    Case("import-values-beyond-any-unit", [*SINGLE, *OUT], 2,
         ("line 2, column 'a' (--u)", "-1e300 rad is not plausible", "check --u-unit"), absent=NO_OUT,
         setup=cell("both.csv", "1,2,10", "-1e300,-2,1e300")),
    Case("import-missing-column", ["import-data", "{dir}/both.csv", "--u", "a,q", "--y", "x,y,z", *OUT], 2,
         ("both.csv", "no column 'q'", "its columns are: a, b, x, y, z, run"), ("{dir}/both.csv",), NO_OUT, files()),
    Case("import-u-column-twice", ["import-data", "{dir}/both.csv", "--u", "a,a", "--y", "x,y,z", *OUT], 2,
         ("--u", "column 'a' twice"), absent=NO_OUT, setup=files()),
    Case("import-column-in-u-and-y", ["import-data", "{dir}/both.csv", "--u", "a,x", "--y", "x,y,z", *OUT], 2,
         ("'x'", "both --u and --y"), absent=NO_OUT, setup=files()),
    Case("import-empty-column-name", ["import-data", "{dir}/both.csv", "--u", "a,,b", "--y", "x,y,z", *OUT], 2,
         ("--u", "none empty"), absent=NO_OUT, setup=files()),
    Case("import-non-numeric", [*SINGLE, *OUT], 2,
         ("both.csv", "line 3", "column 'b' (--u)", "'four' is not a number", "--drop-bad-rows"),
         ("{dir}/both.csv",), NO_OUT, cell("both.csv", "3,4,", "3,four,")),
    Case("import-nan", [*SINGLE, *OUT], 2, ("both.csv", "line 4", "column 'y' (--y)", "NaN or infinite"),
         absent=NO_OUT, setup=cell("both.csv", "12,22,", "12,nan,")),
    Case("import-overflow-is-infinite", [*SINGLE, *OUT], 2, ("line 2", "column 'z'", "'1e400' is NaN or infinite"),
         absent=NO_OUT, setup=cell("both.csv", "20,30", "20,1e400")),
    Case("import-empty-cell", [*PAIR, *OUT], 2, ("obs.csv", "line 3", "column 'x' (--y)", "is empty"),
         absent=NO_OUT, setup=cell("obs.csv", "1,11,", "1,,")),
    Case("import-drop-bad-rows", [*SINGLE, "--drop-bad-rows", *OUT], 0,
         setup=files(both_csv=BOTH.replace("3,4,", "3,x,").replace("12,22", "12,nan")), after=sidecar(_dropped)),
    Case("import-everything-dropped", [*SINGLE, "--drop-bad-rows", *OUT], 2, ("no rows left", "3 with NaN"),
         absent=NO_OUT, setup=files(both_csv="a,b,x,y,z\n1,2,3,4,\n1,2,3,4,nan\n,,,,\n1,inf,1,1,1\n")),
    Case("import-unmatched-ids-all", [*PAIR, "--id", "ID", *OUT], 2, ("no rows left", "6 with unmatched IDs"),
         absent=NO_OUT, setup=files(obs_csv="ID,x,y,z\n7,10,20,30\n8,11,21,31\n9,12,22,32\n")),
    Case("import-out-is-file", [*SINGLE, "--out", "{dir}/both.csv"], 2, ("is the input FILE", "refusing"),
         ("{dir}/both.csv",), setup=files()),
    Case("import-out-is-observations", [*PAIR, "--out", "{dir}/obs.csv"], 2, ("is the input --observations",),
         ("{dir}/obs.csv", "{dir}/in.csv"), setup=files()),
    Case("import-out-is-directory", [*SINGLE, "--out", "{dir}"], 2, ("is a directory",), setup=files()),
    Case("import-y-unit-not-allowed", [*SINGLE, "--y-unit", "inch", *OUT], 2, ("--y-unit", "invalid choice", "inch"),
         absent=NO_OUT, setup=files(), subprocess=True),
    Case("import-y-not-three-columns", ["import-data", "{dir}/both.csv", "--u", "a,b", "--y", "x,y", *OUT], 2,
         ("--y names 2 column(s)", "exactly 3"), absent=NO_OUT, setup=files()),
    Case("import-ragged-row", [*SINGLE, *OUT], 2, ("both.csv", "line 3 has 7 fields, the header has 6"),
         absent=NO_OUT, setup=cell("both.csv", "r1\n3", "r1\n9,3")),
    Case("import-duplicate-id", [*PAIR, "--id", "ID", *OUT], 2, ("in.csv", "'1.0' on line 4", "'1' of line 3",
         "unique"), absent=NO_OUT, setup=cell("in.csv", "\n2,", "\n1.0,")),
    Case("import-empty-id", [*PAIR, "--id", "ID", *OUT], 2, ("obs.csv", "line 2", "empty ID"),
         absent=NO_OUT, setup=cell("obs.csv", "\n0,", "\n ,")),
    Case("import-id-without-observations", [*SINGLE, "--id", "ID", *OUT], 2,
         ("--id is not used without --observations",), absent=NO_OUT, setup=files()),
    Case("import-id-missing-in-observations", [*PAIR, "--id", "ID", *OUT], 2,
         ("obs.csv", "no column 'ID' (--id)", "its columns are: x, y, z"), absent=NO_OUT,
         setup=files(obs_csv="x,y,z\n10,20,30\n11,21,31\n12,22,32\n")),
    Case("import-file-and-obs-counts-differ",
         ["import-data", "{dir}/in.csv", "{dir}/in.csv", "--observations", "{dir}/obs.csv", "--u", "a,b", "--y",
          "x,y,z", *OUT], 2, ("2 FILEs but 1 --observations",), absent=NO_OUT, setup=files()),
    Case("import-row-counts-differ", [*PAIR, *OUT], 2, ("in.csv has 3 rows", "obs.csv has 2", "equal counts"),
         absent=NO_OUT, setup=files(obs_csv="ID,x,y,z\n0,10,20,30\n1,11,21,31\n")),
    Case("import-binary-file", ["import-data", "{dir}/model.npz", "--u", "a,b", "--y", "x,y,z", *OUT], 2,
         ("model.npz", "binary"), ("{dir}/model.npz",), NO_OUT),
    Case("import-not-utf8", [*SINGLE, *OUT], 2, ("both.csv", "not a UTF-8"), absent=NO_OUT,
         setup=files(both_csv=BOTH.encode().replace(b"r2", b"r\xff"))),
    Case("import-empty-file", [*SINGLE, *OUT], 2, ("both.csv", "empty file"), absent=NO_OUT,
         setup=files(both_csv="\n\n")),
    Case("import-header-only", [*SINGLE, *OUT], 2, ("both.csv", "no data rows"), absent=NO_OUT,
         setup=files(both_csv="a,b,x,y,z\n")),
    Case("import-file-not-found", ["import-data", "{dir}/nope.csv", "--u", "a,b", "--y", "x,y,z", *OUT], 2,
         ("nope.csv", "not found"), absent=NO_OUT),
    Case("import-phantom-id-rule", [*PAIR, "--id", "ID", *OUT], 0, ("phantom-ID rule", "by row order"),
         setup=files(obs_csv="ID,x,y,z\n10,20,30\n11,21,31\n12,22,32"),
         after=sidecar(_row_order)),
    Case("import-phantom-needs-the-id-name", [*PAIR, *OUT], 2, ("obs.csv", "line 2 has 3 fields", "phantom-ID"),
         absent=NO_OUT, setup=files(obs_csv="key,x,y,z\n10,20,30\n11,21,31\n12,22,32\n")),
    Case("import-group-column-missing", [*SINGLE, "--group", "session", *OUT], 2, ("no column 'session' (--group)",),
         absent=NO_OUT, setup=files()),
    Case("import-output-locked", [*SINGLE, *OUT], 2, ("being written by another run",), absent=NO_OUT,
         setup=lambda d: (files()(d), _lock(d)), after=_release),
]  # fmt: skip
