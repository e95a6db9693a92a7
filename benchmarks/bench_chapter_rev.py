"""A chapter's whole run at a baseline revision and at HEAD, one after the other on this machine.

    python benchmarks/bench_chapter_rev.py --chapter 05 --rev 2e876ae [--quick] [--out benchmarks/bench_chapter_rev.txt]

For HEAD and for ``--rev``, in that order: the revision's ``lab``, ``notebooks`` and ``data``
(``git archive``) in a fresh temporary folder, the chapter run there by papermill as
``scripts/reproduce`` runs it (kernel python3 of this environment, the folder's ``lab`` first
on PYTHONPATH, one BLAS thread, full mode unless ``--quick``, figures into the temporary
folder, a fresh mesh cache). This environment is HEAD's ``environment.txt``: a baseline from
before numba was pinned runs with the same packages, numba unused; HEAD compiles its kernels
within its run (numba's cache beside the fresh folder is empty, as in a fresh clone). Wall
time of each run (the chapter's time in ``figures/chapter_times.csv`` is the same wall time)
and the process tree's CPU time, and the ratio HEAD / baseline, appended to ``--out``.
Nothing else should run on the machine meanwhile: the two runs are minutes apart, not
interleaved.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from timing import ROOT, Printout

from lab.course.times import machine_name

OUT = Printout()
say = OUT.say


def archive(rev: str, into: Path) -> None:
    """The revision's lab, notebooks and data, extracted under ``into``."""
    into.mkdir(parents=True)
    tar = subprocess.run(
        ["git", "-C", str(ROOT), "archive", rev, "lab", "notebooks", "data"], capture_output=True, check=True
    )
    subprocess.run(["tar", "-x", "-C", str(into)], input=tar.stdout, check=True)


def run_chapter(rev: str, chapter: str, quick: bool, tmp: Path) -> tuple[float, float]:
    """(wall s, CPU s of papermill and its kernel) of the chapter at ``rev``."""
    tree = tmp / rev
    archive(rev, tree)
    notebook = next((tree / "notebooks").glob(f"{chapter}_*.ipynb"))
    env = {**os.environ, "PYTHONPATH": str(tree), "LAB_CACHE_DIR": str(tree / "cache")}
    env.update(OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"
    cmd = [sys.executable, "-m", "papermill", str(notebook), str(tree / "out.ipynb"), "--cwd", str(notebook.parent)]
    cmd += ["-k", "python3", "-p", "figures_dir", str(tree / "figures"), "--no-progress-bar"]
    cmd += ["-p", "quick", "True"] if quick else []
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        sys.exit(f"{notebook.name} at {rev} failed:\n{r.stderr[-4000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--chapter", required=True, help="the chapter's number, e.g. 05")
    ap.add_argument("--rev", required=True, help="the baseline revision")
    ap.add_argument("--quick", action="store_true", help="quick mode (default: full)")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "bench_chapter_rev.txt")
    args = ap.parse_args(argv)
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    mode = "quick" if args.quick else "full"
    now = dt.datetime.now().isoformat(timespec="minutes")
    say(f"## {now}  chapter {args.chapter} ({mode}), HEAD {head.stdout.strip()}")
    flags = f"--chapter {args.chapter} --rev {args.rev}" + " --quick" * args.quick
    say(f"command: python benchmarks/bench_chapter_rev.py {flags}")
    say(f"machine: {machine_name()}; load average at the start {os.getloadavg()[0]:.1f}")
    times = {}
    with tempfile.TemporaryDirectory(prefix="lab-chapter-rev-") as tmp:
        for rev in ("HEAD", args.rev):
            times[rev] = run_chapter(rev, args.chapter, args.quick, Path(tmp))
            say(f"{rev:>8}: wall {times[rev][0]:7.1f} s, CPU {times[rev][1]:7.1f} s")
    ratio = [times["HEAD"][k] / times[args.rev][k] for k in (0, 1)]
    say(f"HEAD / {args.rev}: wall {ratio[0]:.2f}, CPU {ratio[1]:.2f}; load average at the end {os.getloadavg()[0]:.1f}")
    with args.out.open("a") as fh:
        fh.write("\n".join(OUT.lines) + "\n\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
