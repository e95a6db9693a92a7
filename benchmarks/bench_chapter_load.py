"""How much a busy machine stretches a chapter's quick run.

    python benchmarks/bench_chapter_load.py [--load 2] [--chapters 03 04 11]
        [--out benchmarks/bench_chapter_load.txt] [--csv benchmarks/chapter_load.csv]

Runs each chosen chapter in quick mode twice, as ``scripts/reproduce`` runs it (papermill,
kernel ``python3`` of this interpreter's environment, working directory ``notebooks/``,
``-p quick True``, ``-p figures_dir`` a temporary folder; the executed notebook goes to a
temporary folder too, so nothing in the repository is written but the two files below):
once alone and once with ``--load`` CPU-bound processes (``while True: pass``) running
beside it, the two orders alternating from chapter to chapter. Each time is the wall time of
the whole papermill run, kernel start-up included, as the README's time table's.

The printout (the command, the machine, the load averages, per chapter both times and their
ratio, the median and range of the ratios) is printed and appended to ``--out``; the numbers
replace ``--csv`` (:mod:`lab.course.load_times`), which ``scripts/chapter-times --write``
turns into the line under the README's time table. The CSV lives in ``benchmarks/``, not
``figures/``: only ``scripts/reproduce`` writes ``figures/``.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from timing import run_beside_load  # noqa: E402

from lab.course.load_times import LOAD_TIMES, write_load_times  # noqa: E402
from lab.course.times import machine_name  # noqa: E402


def run_chapter(nb: Path, load: int) -> tuple[float, tuple[float, float, float]]:
    """Wall time (s) of one quick papermill run of ``nb`` with ``load`` CPU-bound processes
    beside it, and the load averages at its end; exits with the run's log if it fails."""
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    with tempfile.TemporaryDirectory(prefix="lab-chapter-load-") as tmp:
        cmd = [sys.executable, "-m", "papermill", str(nb), str(Path(tmp) / nb.name), "--cwd", str(nb.parent),
               "-k", "python3", "-p", "figures_dir", str(Path(tmp) / "figures"), "-p", "quick", "True"]  # fmt: skip
        r, wall, loadavg = run_beside_load(cmd, load, env=env)
    if r.returncode:
        sys.exit(
            f"bench_chapter_load: {nb.name} failed (exit {r.returncode}) with {load} beside it:\n{r.stderr[-3000:]}"
        )
    return wall, loadavg


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--load", type=int, default=2, help="CPU-bound processes beside the loaded run (1-16)")
    p.add_argument("--chapters", nargs="+", default=["03", "04", "11"], help="chapter numbers (NN)")
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "bench_chapter_load.txt", help="the printout")
    p.add_argument("--csv", type=Path, default=ROOT / LOAD_TIMES, help="the numbers (replaced)")
    args = p.parse_args(argv)
    if not 1 <= args.load <= 16:
        p.error("--load must be 1-16")
    notebooks = []
    for c in args.chapters:
        found = sorted((ROOT / "notebooks").glob(f"{c}_*.ipynb")) if len(c) == 2 and c.isdigit() else []
        if len(found) != 1:
            p.error(f"--chapters: no chapter {c!r} (NN, a number of notebooks/NN_*.ipynb)")
        notebooks.append(found[0])
    machine, today = machine_name(), dt.date.today().isoformat()
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    before = os.getloadavg()
    lines = [
        f"## {dt.datetime.now().isoformat(timespec='minutes')}  HEAD {head.stdout.strip()}  {machine}",
        "command: python benchmarks/bench_chapter_load.py "
        + shlex.join(["--load", str(args.load), "--chapters", *args.chapters]),  # fmt: skip
        f"load average before the first run: {before[0]:.1f}/{before[1]:.1f}/{before[2]:.1f}; "
        f"idle runs: nothing of ours beside the chapter; loaded runs: {args.load} CPU-bound process(es) beside it",
        f"{'chapter':<32} {'idle s':>8} {'loaded s':>9} {'ratio':>6}   load average at the end (idle, loaded)",
    ]
    print("\n".join(lines), flush=True)
    rows = []
    for k, nb in enumerate(notebooks):
        got = {}
        for load in (0, args.load) if k % 2 == 0 else (args.load, 0):  # alternate which goes first
            got[load] = run_chapter(nb, load)
        idle, loaded = f"{got[0][0]:.1f}", f"{got[args.load][0]:.1f}"
        ratio = round(float(loaded) / float(idle), 2)
        first = "idle" if k % 2 == 0 else "loaded"
        lines.append(
            f"{nb.name:<32} {idle:>8} {loaded:>9} {ratio:>6.2f}   {got[0][1][0]:.1f}, {got[args.load][1][0]:.1f}"
            f"  ({first} first)"
        )
        print(lines[-1], flush=True)
        rows.append({"chapter": nb.name, "quick_idle_s": idle, "quick_loaded_s": loaded, "ratio": f"{ratio:.2f}",
                     "load": args.load, "date": today, "machine": machine})  # fmt: skip
    ratios = sorted(float(r["ratio"]) for r in rows)
    csv_path = args.csv.resolve()
    shown = csv_path.relative_to(ROOT) if csv_path.is_relative_to(ROOT) else csv_path
    lines.append(
        f"ratio loaded/idle: median {statistics.median(ratios):.2f}, range {ratios[0]:.2f}-{ratios[-1]:.2f} "
        f"over {len(ratios)} chapter(s) -> {shown}"
    )
    print(lines[-1])
    write_load_times(args.csv, rows)
    new = not args.out.exists()
    with args.out.open("a") as fh:
        if new:
            fh.write("# Output of benchmarks/bench_chapter_load.py (appended per invocation).\n\n")
        fh.write("\n".join(lines) + "\n\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
