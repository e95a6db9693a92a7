"""Fault-sweep rows (tests/sweep.py format) for ``compare``: bad data, flags, results files and floors.

The rows use the sweep's ``data.csv`` (60 FEM samples, one sequence: a group split cuts it
into blocks) and the two cheapest models; a setup writes the bad versions: ``bad.csv`` (a
hand-written CSV without a sidecar), a results file of other settings or another kind, an
inspect report of another dataset.
"""

import json
from pathlib import Path

from sweep import Case

BASE = ["compare", "{dir}/data.csv", "--models", "linear", "poly3", "--n-splits", "1", "--history", "0", "--jobs", "1"]
OUT = ["--out", "{dir}/c.csv"]
KEEP = ("{dir}/data.csv", "{dir}/data.csv.json")
NO_OUT = ("{dir}/c.csv", "{dir}/c.csv.json")
ROWS = "u0,u1,x,y,z\n"
GOOD = "".join(f"{i * 0.1},{(i % 3) * 0.2},0.0{i},0.01,0.02\n" for i in range(30))


def bad_csv(text: str):
    """A setup writing ``bad.csv`` with ``text`` (no sidecar)."""

    def setup(d: Path):
        (d / "bad.csv").write_text(text)

    return setup


def report(sha: str | None = "0" * 64, path: str = "other.csv", kind: str = "lab.inspect", floor_m=0.01):
    """A setup writing ``r.json``: an inspect report of the dataset ``path`` hashing to ``sha``."""

    def setup(d: Path):
        r = {"kind": kind, "dataset": {"path": path, "csv_sha256": sha}, "floor": {"floor_m": floor_m}}
        (d / "r.json").write_text(json.dumps(r))

    return setup


def own_report(floor_m):
    """A setup writing ``r.json``: an inspect report of the sweep's ``data.csv`` with ``floor_m``."""

    def setup(d: Path):
        report(json.loads((d / "data.csv.json").read_text())["csv_sha256"], "data.csv", floor_m=floor_m)(d)

    return setup


def earlier_run(fraction: str):
    """A setup running ``compare`` once with ``--test-fraction fraction`` (writes c.csv)."""

    def setup(d: Path):
        from lab.cli import main

        assert main([a.replace("{dir}", str(d)) for a in [*BASE, "--test-fraction", fraction, *OUT]]) == 0

    return setup


def damaged_row(d: Path):
    """An earlier run's c.csv whose first row's test_rms_m is not a number."""
    earlier_run("0.1")(d)
    head, first, *rest = (d / "c.csv").read_text().splitlines()
    cells = first.split(",")
    cells[head.split(",").index("test_rms_m")] = "zero"
    (d / "c.csv").write_text("\n".join([head, ",".join(cells), *rest]) + "\n")


def _rows(d: Path):
    text = (d / "c.csv").read_text().splitlines()
    side = json.loads((d / "c.csv.json").read_text())
    # linear and poly3 on random, group(blocks) and sequential: 6 rows
    assert len(text) == 7 and ",group(blocks)," in text[3] and side["floor"]["floor_m"] == 0.01


# fmt: off
COMPARE_CASES = [
    Case("compare-ok-with-floor", [*BASE, "--floor", "{dir}/r.json", *OUT], 0, unchanged=KEEP, after=_rows,
         setup=lambda d: report(json.loads((d / "data.csv.json").read_text())["csv_sha256"], "data.csv")(d)),
    Case("compare-missing-data", ["compare", "{dir}/nope.csv", *OUT], 2, ("dataset not found", "nope.csv"),
         absent=NO_OUT),
    Case("compare-nan", ["compare", "{dir}/bad.csv", "--models", "linear", *OUT], 2, ("bad.csv", "line 3", "NaN"),
         setup=bad_csv(ROWS + "0,0,0,0,0\n1,nan,0,0,0\n" + GOOD), absent=NO_OUT),
    Case("compare-missing-column", ["compare", "{dir}/bad.csv", *OUT], 2, ("bad.csv", "header"),
         setup=bad_csv("u0,u1,x,y\n0,0,0,0\n"), absent=NO_OUT),
    Case("compare-too-few-rows", ["compare", "{dir}/bad.csv", "--models", "linear", *OUT], 2,
         ("too few to train on",), setup=bad_csv(ROWS + "".join(GOOD.splitlines(True)[:3])), absent=NO_OUT),
    Case("compare-models-bogus", [*BASE, "--models", "bogus", *OUT], 2, ("--models", "unknown: bogus"), KEEP,
         NO_OUT),
    Case("compare-splits-bogus", [*BASE, "--splits", "time", *OUT], 2, ("--splits", "unknown: time"), KEEP, NO_OUT),
    Case("compare-n-splits-zero", [*BASE, "--n-splits", "0", *OUT], 2, ("--n-splits", "positive integer"), KEEP,
         NO_OUT),
    Case("compare-n-splits-huge", [*BASE, "--n-splits", "1000000", *OUT], 2, ("--n-splits", "at most 100"), KEEP,
         NO_OUT),
    Case("compare-history-huge", [*BASE, "--history", "11", *OUT], 2, ("--history", "at most 10"), KEEP, NO_OUT),
    Case("compare-history-negative", [*BASE, "--history", "-1", *OUT], 2, ("--history", "integers >= 0"), KEEP,
         NO_OUT),
    Case("compare-ns-larger-than-training", [*BASE, "--ns", "100", *OUT], 2,
         ("--ns 100", "below the 54 training rows"), KEEP, NO_OUT),
    Case("compare-ns-tiny", [*BASE, "--ns", "3", *OUT], 2, ("--ns", "integers >= 20"), KEEP, NO_OUT),
    Case("compare-test-fraction-nan", [*BASE, "--test-fraction", "nan", *OUT], 2,
         ("--test-fraction", "from 0.01 to 0.5"), KEEP, NO_OUT),
    Case("compare-test-fraction-one", [*BASE, "--test-fraction", "1", *OUT], 2,
         ("--test-fraction", "from 0.01 to 0.5"), KEEP, NO_OUT),
    Case("compare-jobs-zero", [*BASE[:-2], "--jobs", "0", *OUT], 2, ("--jobs", "positive integer"), KEEP, NO_OUT),
    Case("compare-out-is-data", [*BASE, "--out", "{dir}/data.csv"], 2, ("is the input DATA", "refusing"), KEEP),
    Case("compare-out-is-sidecar", [*BASE, "--out", "{dir}/data.csv.json"], 2, ("is the input DATA sidecar",), KEEP),
    Case("compare-out-is-directory", [*BASE, "--out", "{dir}/sub"], 2, ("is a directory",),
         setup=lambda d: (d / "sub").mkdir()),
    Case("compare-floor-of-another-dataset", [*BASE, "--floor", "{dir}/r.json", *OUT], 2,
         ("--floor", "r.json", "other.csv", "another dataset"), KEEP, NO_OUT, setup=report()),
    Case("compare-floor-not-a-report", [*BASE, "--floor", "{dir}/r.json", *OUT], 2,
         ("--floor", "not an inspect report"), KEEP, NO_OUT, setup=report(kind="lab.model_comparison")),
    Case("compare-floor-missing", [*BASE, "--floor", "{dir}/none.json", *OUT], 2,
         ("--floor", "not a readable inspect report"), KEEP, NO_OUT),
    Case("compare-floor-nan", [*BASE, "--floor", "{dir}/r.json", *OUT], 2,
         ("--floor", "r.json", "has no floor", "nan"), KEEP, NO_OUT, setup=own_report(float("nan"))),
    Case("compare-floor-negative", [*BASE, "--floor", "{dir}/r.json", *OUT], 2,
         ("--floor", "has no floor", "-0.01"), KEEP, NO_OUT, setup=own_report(-0.01)),
    Case("compare-floor-not-a-number", [*BASE, "--floor", "{dir}/r.json", *OUT], 2,
         ("--floor", "has no floor", "'1 cm'"), KEEP, NO_OUT, setup=own_report("1 cm")),
    Case("compare-floor-is-out", [*BASE, "--floor", "{dir}/c.csv", *OUT], 2, ("is the input --floor",), KEEP),
    Case("compare-resumed-with-other-settings", [*BASE, "--test-fraction", "0.2", *OUT], 2,
         ("c.csv was made with other settings", "test_fraction 0.3 (this run: 0.2)", "choose another --out"),
         ("{dir}/c.csv", "{dir}/c.csv.json"), setup=earlier_run("0.3")),
    Case("compare-out-not-a-compare-file", [*BASE, *OUT], 2, ("c.csv", "not a compare file"), ("{dir}/c.csv",),
         setup=lambda d: (d / "c.csv").write_text("a,b\n1,2\n")),
    Case("compare-out-without-sidecar", [*BASE, *OUT], 2, ("c.csv.json", "settings are unknown"), ("{dir}/c.csv",),
         setup=lambda d: (earlier_run("0.1")(d), (d / "c.csv.json").unlink())),
    Case("compare-out-damaged-row", [*BASE, *OUT], 2, ("c.csv", "line 2", "test_rms_m", "not a number"),
         ("{dir}/c.csv",), setup=damaged_row),
]
# fmt: on
