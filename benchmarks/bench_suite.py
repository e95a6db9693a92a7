"""The test suite's time and reliability, idle and on a loaded machine.

    python benchmarks/bench_suite.py [--load 2] [--runs 3] [--out benchmarks/bench_suite.txt]

Each run clones this repository's committed HEAD into a fresh temporary directory and runs
``bash .ci/run`` there (CI=true: the ``.venv`` is built from the pip cache, then
``scripts/test``), with ``--load`` CPU-bound processes (``while True: pass``) running beside
it for the whole run, as a machine shared with other jobs. Per run it records the exit
code, the wall time of ``.ci/run`` and of the tests alone (pytest's summary line), the CPU
time of ``.ci/run`` (its whole process tree: what a busy machine has to find), the
counts, the load average, and pytest's ten slowest tests (``--durations=10`` in pytest.ini).
The report is appended to ``--out``, headed by the machine (its CPUs and their model: the
times depend on it); the goals are 6 min for the suite and 15 min for ``.ci/run`` idle,
25 min under a load of two (docs/testing.md).
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from timing import run_beside_load

from lab.course.times import machine_name

ROOT = Path(__file__).resolve().parent.parent


def one_run(load: int, log_dir: Path, k: int) -> dict:
    with tempfile.TemporaryDirectory(prefix="lab-suite-") as tmp:
        clone = Path(tmp) / "lab"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
        env = {**os.environ, "CI": "true"}
        env.pop("VIRTUAL_ENV", None)
        r, wall, loadavg = run_beside_load(["bash", ".ci/run"], load, cwd=clone, env=env)
    out = r.stdout + r.stderr
    (log_dir / f"bench_suite_run{k}_load{load}.log").write_text(out)
    summary = [ln for ln in out.splitlines() if re.search(r"\d+ (passed|failed)", ln) and " in " in ln]
    slowest = []
    if "slowest 10 durations" in out:
        block = out.split("slowest 10 durations", 1)[1].splitlines()[1:12]
        slowest = [ln for ln in block if re.match(r"\s*\d+\.\d+s ", ln)]
    return {"rc": r.returncode, "wall_s": wall, "cpu_s": r.cpu_s, "summary": summary[-1] if summary else "?",
            "load": loadavg, "slowest": slowest}  # fmt: skip


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--load", type=int, default=2, help="CPU-bound processes beside the suite")
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "bench_suite.txt")
    args = p.parse_args(argv)
    if not (0 <= args.load <= 16 and 1 <= args.runs <= 10):
        p.error("--load must be 0-16 and --runs 1-10")
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    lines = [
        f"## {dt.datetime.now().isoformat(timespec='minutes')}  HEAD {head.stdout.strip()}  "
        f"load {args.load} CPU-bound process(es), {machine_name()}",
        f"command: python benchmarks/bench_suite.py --load {args.load} --runs {args.runs}",
    ]
    failed = 0
    for k in range(1, args.runs + 1):
        res = one_run(args.load, args.out.parent, k)
        failed += res["rc"] != 0
        lines.append(
            f"run {k}: exit {res['rc']}, .ci/run {res['wall_s'] / 60:.1f} min (CPU {res['cpu_s'] / 60:.1f} min, the "
            f"build of .venv included); {res['summary'].strip('= ')}; "
            f"load average at the end {res['load'][0]:.1f}/{res['load'][1]:.1f}/{res['load'][2]:.1f}"
        )
        lines += [f"    {s.strip()}" for s in res["slowest"]]
        print(lines[-1 - len(res["slowest"])], flush=True)
    with args.out.open("a") as fh:
        fh.write("\n".join(lines) + "\n\n")
    print("\n".join(lines))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
