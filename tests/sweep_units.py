"""Fault-sweep rows (tests/sweep.py format) for values in the wrong unit and for what an
import reads: tips in millimetres read as metres, angles in degrees read as radians (in
``import-data`` and ``simulate --commands``); a user's file named like an output's lock
(``OUT.lock``: refused, never deleted, by ``import-data``, ``inspect``, ``compare`` and
``track``); IDs compared exactly; pipes and devices, numbers outside ASCII or with ``_``,
and a header naming a column twice.
"""

import os
from pathlib import Path

import numpy as np
from sweep import COARSE, Case

from lab.data import read_dataset

GOOD = "a,b,x,y,z\n0.1,0.2,0.01,0.02,0.03\n0.3,0.4,0.011,0.021,0.031\n"
IMPORT = ["import-data", "{dir}/f.csv", "--u", "a,b", "--y", "x,y,z"]
OUT = ["--out", "{dir}/o.csv"]
NO_OUT = ("{dir}/o.csv", "{dir}/o.csv.json")
IN_MM = "a,b,x,y,z\n0.1,0.2,10,182,30\n0.3,0.4,11,180,31\n"
USERS_LOCK = "my notes, in a file that happens to be named like the lock\n"


def write(**texts):
    """A setup writing each ``name_ext="text"`` as ``name.ext`` (``o_csv_lock`` -> ``o.csv.lock``)."""

    def setup(d: Path):
        for name, text in texts.items():
            (d / name.replace("_", ".")).write_text(text)

    return setup


def _fifo(d: Path):
    os.mkfifo(d / "f.csv")


def _pairs_exactly(d: Path):
    u, y, _ = read_dataset(d / "o.csv")
    np.testing.assert_array_equal(u, [[1, 2], [3, 4]])
    np.testing.assert_allclose(y, [[0.004, 0.005, 0.006], [0.001, 0.002, 0.003]])


def _lock_kept(d: Path):
    assert (d / "o.csv").exists() and (d / "o.csv.lock").read_bytes() == b""


IDS_17 = ("90071992547409930", "90071992547409931")  # one float apart: 2^56 + 2 and + 3
IDS_19 = ("1732860000000000001", "1732860000000000002", "1732860000000000003")  # nanosecond timestamps
PAIR = ["import-data", "{dir}/in.csv", "--observations", "{dir}/obs.csv", "--id", "ID", "--u", "a,b", "--y", "x,y,z"]

UNITS_CASES: list = [
    # --- values implausible for their unit: the unit they look like is named ---
    Case("units-tips-in-mm-read-as-m", [*IMPORT, *OUT], 2,
         ("f.csv", "line 2, column 'x' (--y)", "10 m is not plausible for a position", "look like mm, not m",
          "give --y-unit mm"), ("{dir}/f.csv",), NO_OUT, write(f_csv=IN_MM)),
    Case("units-tips-in-mm-with-y-unit-mm", [*IMPORT, "--y-unit", "mm", *OUT], 0, setup=write(f_csv=IN_MM)),
    Case("units-angles-in-degrees-read-as-rad", [*IMPORT, *OUT], 2,
         ("line 3, column 'b' (--u)", "90 rad is not plausible for an angle", "look like deg, not rad",
          "convert them to rad"), ("{dir}/f.csv",), NO_OUT, write(f_csv="a,b,x,y,z\n1,2,0,0,0\n1,90,0,0,0\n")),
    Case("units-tensions-in-mN-read-as-N", [*IMPORT, "--u-unit", "N", *OUT], 2,
         ("column 'a' (--u)", "20000 N is not plausible for a tension", "look like mN, not N"), ("{dir}/f.csv",),
         NO_OUT, write(f_csv="a,b,x,y,z\n20000,2,0,0,0\n")),
    Case("units-kpa-read-as-bar", [*IMPORT, "--u-unit", "bar", *OUT], 2,
         ("200 bar is not plausible for a pressure", "look like kPa, not bar", "give --u-unit kPa"),
         ("{dir}/f.csv",), NO_OUT, write(f_csv="a,b,x,y,z\n200,2,0,0,0\n")),
    Case("units-simulate-commands-in-degrees",
         ["simulate", "--commands", "{dir}/U.csv", "--jobs", "1", "--no-progress", *COARSE, *OUT], 2,
         ("U.csv", "line 3, column 'u2'", "outside", "look like deg, not rad", "in its unit (rad for input u2)"),
         ("{dir}/U.csv",), (*NO_OUT, "{dir}/o.csv.chunks"), write(U_csv="u0,u1,u2\n0,0,0\n0,0,90\n")),
    # --- a user's file named OUT.lock is refused and kept; an empty lock left by a killed run stays ---
    Case("units-lock-named-input-kept", ["import-data", "{dir}/o.csv.lock", "--u", "a,b", "--y", "x,y,z", *OUT], 2,
         ("is the input FILE",), ("{dir}/o.csv.lock",), NO_OUT, write(o_csv_lock=GOOD)),
    Case("units-lock-import-users-file-kept", [*IMPORT, *OUT], 2, ("o.csv.lock exists and is not a lock file",),
         ("{dir}/o.csv.lock", "{dir}/f.csv"), NO_OUT, write(f_csv=GOOD, o_csv_lock=USERS_LOCK)),
    Case("units-lock-empty-left-as-it-was", [*IMPORT, *OUT], 0, setup=write(f_csv=GOOD, o_csv_lock=""),
         after=_lock_kept),
    Case("units-lock-inspect-users-file-kept", ["inspect", "{dir}/data.csv", "--out", "{dir}/r.json"], 2,
         ("r.json.lock exists and is not a lock file",), ("{dir}/r.json.lock", "{dir}/data.csv"), ("{dir}/r.json",),
         write(r_json_lock=USERS_LOCK)),
    Case("units-lock-compare-users-file-kept",
         ["compare", "{dir}/data.csv", "--models", "linear", "--n-splits", "1", "--history", "0", "--jobs", "1",
          "--out", "{dir}/c.csv"], 2,
         ("c.csv.lock exists and is not a lock file",), ("{dir}/c.csv.lock", "{dir}/data.csv"),
         ("{dir}/c.csv", "{dir}/c.csv.json"), write(c_csv_lock=USERS_LOCK)),
    Case("units-lock-track-users-file-kept",
         ["track", "--rig", "none", "--model", "{dir}/model.npz", "--trajectory", "{dir}/traj.csv",
          "--out", "{dir}/r.json"], 2,
         ("r.json.lock exists and is not a lock file",), ("{dir}/r.json.lock", "{dir}/traj.csv"), ("{dir}/r.json",),
         write(r_json_lock=USERS_LOCK)),
    Case("units-lock-is-a-link", [*IMPORT, *OUT], 2, ("o.csv.lock exists and is not a lock file (not a plain file)",),
         ("{dir}/notes.txt",), NO_OUT,
         lambda d: (write(f_csv=GOOD, notes_txt=USERS_LOCK)(d), os.symlink(d / "notes.txt", d / "o.csv.lock"))),
    # --- IDs are compared exactly, not as floats ---
    Case("units-ids-one-float-apart-pair-exactly", [*PAIR, "--y-unit", "mm", *OUT], 0,
         setup=write(in_csv=f"ID,a,b\n{IDS_17[0]},1,2\n{IDS_17[1]},3,4\n",
                     obs_csv=f"ID,x,y,z\n{IDS_17[1]},1,2,3\n{IDS_17[0]},4,5,6\n"), after=_pairs_exactly),
    Case("units-ids-19-digit-timestamps-unique", [*PAIR, "--y-unit", "mm", *OUT], 0,
         setup=write(in_csv="ID,a,b\n" + "".join(f"{i},1,2\n" for i in IDS_19),
                     obs_csv="ID,x,y,z\n" + "".join(f"{i},1,2,3\n" for i in IDS_19))),
    # --- what an import reads: regular files, ASCII numbers, one name per column ---
    Case("units-import-a-device", ["import-data", "/dev/zero", "--u", "a,b", "--y", "x,y,z", *OUT], 2,
         ("/dev/zero is not a regular file",), absent=NO_OUT),
    Case("units-import-a-pipe", [*IMPORT, *OUT], 2, ("f.csv is not a regular file",), absent=NO_OUT, setup=_fifo),
    Case("units-number-with-underscores", [*IMPORT, *OUT], 2,
         ("line 3, column 'a' (--u)", "'1_000' is not a number", "ASCII digits"), absent=NO_OUT,
         setup=write(f_csv=GOOD.replace("0.3,", "1_000,"))),
    Case("units-arabic-indic-digits", [*IMPORT, *OUT], 2, ("line 2, column 'b' (--u)", "is not a number"),
         absent=NO_OUT, setup=write(f_csv=GOOD.replace("0.2,", "\u0660.\u0662,"))),
    Case("units-full-width-digits", [*IMPORT, *OUT], 2, ("line 2, column 'x' (--y)", "is not a number"),
         absent=NO_OUT, setup=write(f_csv=GOOD.replace("0.01,", "\uff10.\uff10\uff11,"))),
    Case("units-header-names-a-column-twice", [*IMPORT, *OUT], 2,
         ("f.csv", "line 1", "names the column(s) 'q' more than once"), ("{dir}/f.csv",), NO_OUT,
         write(f_csv="a,b,x,y,z,q,q\n0.1,0.2,0.01,0.02,0.03,1,2\n")),
]  # fmt: skip
