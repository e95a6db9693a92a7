"""Import time of the shipped ASL Trunk data: 4,158 rows from 29 file pairs, process start included.

    python benchmarks/bench_import.py            # a few seconds; writes benchmarks/bench_import.txt

Runs the two ``python -m lab import-data`` commands recorded in the shipped sidecars
(data/asl_trunk_oct2024.csv.json, data/asl_trunk_sep2024.csv.json; made by scripts/import-asl)
as fresh processes into a temporary folder, three times, and reports the best wall time of
each and of both together -- the whole command as a user runs it: interpreter start, reading
and checking the 58 raw files, writing the datasets. The budget is 5 s for both. The written
CSVs must equal the shipped ones byte for byte.
"""

import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from lab.data import read_dataset, sidecar_path

ROOT = Path(__file__).resolve().parent.parent
NAMES = ("asl_trunk_oct2024", "asl_trunk_sep2024")
BUDGET_S = 5.0
REPEATS = 3


def command(name: str, out: Path) -> list[str]:
    """The shipped dataset's command, writing to ``out`` instead."""
    _, _, meta = read_dataset(ROOT / "data" / f"{name}.csv")
    words = shlex.split(meta["command"])[3:]
    words[words.index("--out") + 1] = str(out)
    return [sys.executable, "-m", "lab", *words]


def main() -> None:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    best = {name: float("inf") for name in NAMES}
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(REPEATS):
            for name in NAMES:
                out = Path(tmp) / f"{name}.csv"
                argv = command(name, out)
                t0 = time.perf_counter()
                subprocess.run(argv, cwd=ROOT, env=env, check=True, capture_output=True)
                best[name] = min(best[name], time.perf_counter() - t0)
                u, _, _ = read_dataset(out)
                rows[name] = len(u)
                shipped = ROOT / "data" / f"{name}.csv"
                assert out.read_bytes() == shipped.read_bytes(), f"{name}: the import differs from the shipped CSV"
                sidecar_path(out).unlink()
    total = sum(best.values())
    lines = [f"python -m lab import-data, best of {REPEATS} runs, process start included (one thread per process)"]
    lines += [f"  {name}: {rows[name]:>5} rows  {best[name]:6.2f} s" for name in NAMES]
    verdict = "ok" if total < BUDGET_S else "OVER"
    lines.append(f"  both: {sum(rows.values()):>5} rows  {total:6.2f} s  (budget {BUDGET_S:g} s: {verdict})")
    text = "\n".join(lines) + "\n"
    print(text, end="")
    (ROOT / "benchmarks" / "bench_import.txt").write_text(text)
    if total >= BUDGET_S:
        sys.exit(1)


if __name__ == "__main__":
    main()
