"""Table I is updated under a lock kept beside the table (not in /tmp), so writers on
different machines that share the file system serialise; the lock file goes when done."""

from __future__ import annotations

import multiprocessing as mp
import time

from filelock import FileLock

from lab.studies import table1


def _writer(csv, md, condition, n):
    for k in range(n):
        table1.update_table1({condition: {"circle": 0.001 * (k + 1)}}, csv, md, source=condition)


def test_concurrent_updates_keep_every_row(tmp_path):
    csv, md = tmp_path / "table1.csv", tmp_path / "table1.md"
    ctx = mp.get_context("spawn")
    procs = [
        ctx.Process(target=_writer, args=(csv, md, c, 15))
        for c in ("Sim Data + Sim Robot", "Real Data + Real Robot", "Sim Data + Real Robot")
    ]
    for p in procs:
        p.start()
    for p in procs:
        p.join(120)
        assert p.exitcode == 0
    rows = table1.read_table1(csv)
    assert len(rows) == 3 and all(abs(float(r["circle_cm"]) - 0.015) < 1e-12 for r in rows.values())
    assert not list(tmp_path.glob(".*.lock"))  # nothing left beside the figures


def test_the_lock_lives_beside_the_table(tmp_path):
    """While another machine holds ``.table1.csv.lock`` beside the table, an update waits."""
    csv, md = tmp_path / "table1.csv", tmp_path / "table1.md"
    held = FileLock(tmp_path / ".table1.csv.lock")
    held.acquire()
    p = mp.get_context("spawn").Process(target=_writer, args=(csv, md, "Sim Data + Sim Robot", 1))
    p.start()
    try:
        t0 = time.monotonic()
        while time.monotonic() - t0 < 3.0:  # (a writer that ignored the lock would write the table now)
            assert not csv.exists() and p.exitcode is None
            time.sleep(0.1)
    finally:
        held.release()
    p.join(120)
    assert p.exitcode == 0 and csv.exists()
