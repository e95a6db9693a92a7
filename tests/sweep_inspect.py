"""Fault-sweep rows (tests/sweep.py format) for ``inspect``: bad datasets, sidecars and flags.

The rows use the sweep's ``data.csv`` (60 FEM samples, one sequence); a setup writes the
bad versions: ``bad.csv`` (a hand-written CSV without a sidecar) or an edited sidecar.
"""

import json
from pathlib import Path

from sweep import Case

INSPECT = ["inspect", "{dir}/data.csv"]
OUT = ["--out", "{dir}/r.json"]
KEEP = ("{dir}/data.csv", "{dir}/data.csv.json")
NO_REPORT = ("{dir}/r.json",)


def bad_csv(text: str):
    """A setup writing ``bad.csv`` with ``text`` (no sidecar)."""

    def setup(d: Path):
        (d / "bad.csv").write_text(text)

    return setup


def sidecar(**changes):
    """A setup changing keys of ``data.csv.json`` (a value None removes the key)."""

    def setup(d: Path):
        side = d / "data.csv.json"
        meta = json.loads(side.read_text())
        meta.update(changes)
        side.write_text(json.dumps(meta))

    return setup


def _report(d: Path):
    r = json.loads((d / "r.json").read_text())
    assert r["format_version"] == 1 and r["kind"] == "lab.inspect" and r["n_rows"] == 60
    assert r["floor"]["n_pairs"] > 0 and r["n_sequences"] == 2


ROWS = "u0,u1,x,y,z\n"
GOOD = "".join(f"{i * 0.1},{(i % 3) * 0.2},0.0{i},0.01,0.02\n" for i in range(9))

# fmt: off
INSPECT_CASES = [
    Case("inspect-ok-two-sequences", [*INSPECT, "--bootstrap", "20", *OUT], 0, unchanged=KEEP,
         setup=sidecar(sequence_starts=[0, 30]), after=_report),
    Case("inspect-out-is-input", [*INSPECT, "--out", "{dir}/data.csv"], 2, ("--out", "JSON"), unchanged=KEEP),
    Case("inspect-out-is-sidecar", [*INSPECT, "--out", "{dir}/data.csv.json"], 2,
         ("is the input DATA sidecar", "refusing"), unchanged=KEEP),
    Case("inspect-out-is-directory", [*INSPECT, "--out", "{dir}/sub.json"], 2, ("is a directory",),
         setup=lambda d: (d / "sub.json").mkdir()),
    Case("inspect-missing-data", ["inspect", "{dir}/nope.csv", *OUT], 2, ("dataset not found", "nope.csv"),
         absent=NO_REPORT),
    Case("inspect-nan", ["inspect", "{dir}/bad.csv", *OUT], 2, ("bad.csv", "line 3", "NaN"),
         setup=bad_csv(ROWS + "0,0,0,0,0\n1,nan,0,0,0\n" + GOOD), absent=NO_REPORT),
    Case("inspect-missing-column", ["inspect", "{dir}/bad.csv", *OUT], 2, ("bad.csv", "header", "u0,u1,x,y"),
         setup=bad_csv("u0,u1,x,y\n0,0,0,0\n"), absent=NO_REPORT),
    Case("inspect-non-numeric", ["inspect", "{dir}/bad.csv", *OUT], 2, ("bad.csv", "line 2", "non-numeric"),
         setup=bad_csv(ROWS + "0,zero,0,0,0\n" + GOOD), absent=NO_REPORT),
    Case("inspect-tip-not-metres", ["inspect", "{dir}/bad.csv", *OUT], 2, ("bad.csv", "row 0", "line 2", "metres"),
         setup=bad_csv(ROWS + "0,0,120.0,0,0\n" + GOOD), absent=NO_REPORT),
    Case("inspect-huge-command", ["inspect", "{dir}/bad.csv", *OUT], 2, ("bad.csv", "u: row 1", "beyond 1e+06"),
         setup=bad_csv(ROWS + "0,0,0,0,0\n-1e300,0,0,0,0\n" + GOOD), absent=NO_REPORT),
    Case("inspect-too-few-rows", ["inspect", "{dir}/bad.csv", *OUT], 2,
         ("bad.csv", "3 rows", "too few", "--neighbours 5"),
         setup=bad_csv(ROWS + "".join(GOOD.splitlines(True)[:3])), absent=NO_REPORT),
    Case("inspect-corrupt-sidecar", [*INSPECT, *OUT], 2, ("data.csv.json", "corrupt metadata JSON"),
         setup=lambda d: (d / "data.csv.json").write_text("{not json"), absent=NO_REPORT),
    Case("inspect-bad-sequence-starts", [*INSPECT, *OUT], 2, ("data.csv.json", "sequence_starts", "below 60"),
         setup=sidecar(sequence_starts=[0, 100]), unchanged=KEEP, absent=NO_REPORT),
    Case("inspect-sidecar-stale", [*INSPECT, *OUT], 2, ("does not match its sidecar",),
         setup=lambda d: (d / "data.csv").write_text((d / "data.csv").read_text().replace("0.", "1.", 1)),
         absent=NO_REPORT),
    Case("inspect-neighbours-zero", [*INSPECT, "--neighbours", "0", *OUT], 2, ("--neighbours", "positive integer"),
         absent=NO_REPORT),
    Case("inspect-neighbours-huge", [*INSPECT, "--neighbours", "1000", *OUT], 2, ("--neighbours", "at most 50"),
         absent=NO_REPORT),
    Case("inspect-bootstrap-negative", [*INSPECT, "--bootstrap", "-5", *OUT], 2, ("--bootstrap",),
         absent=NO_REPORT),
    Case("inspect-bootstrap-huge", [*INSPECT, "--bootstrap", "10000000", *OUT], 2, ("--bootstrap", "at most 5000"),
         absent=NO_REPORT),
    Case("inspect-outlier-mads-nan", [*INSPECT, "--outlier-mads", "nan", *OUT], 2, ("--outlier-mads", "finite"),
         absent=NO_REPORT),
    Case("inspect-outlier-mads-negative", [*INSPECT, "--outlier-mads", "-1", *OUT], 2, ("--outlier-mads",),
         absent=NO_REPORT),
    Case("inspect-block-rows-huge", [*INSPECT, "--block-rows", "1000000", *OUT], 2, ("--block-rows", "at most 1000"),
         absent=NO_REPORT),
    Case("inspect-seed-negative", [*INSPECT, "--seed", "-1", *OUT], 2, ("--seed", "integer >= 0"),
         absent=NO_REPORT),
    Case("inspect-no-out", INSPECT, 2, ("--out",), subprocess=True),
]
# fmt: on
