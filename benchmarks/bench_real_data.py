"""Which model to recommend on measured data: checks on the cached ``compare`` results of the ASL Trunk.

    python benchmarks/bench_real_data.py      # a second; writes benchmarks/bench_real_data.txt

Reads data/asl_trunk_compare_oct2024.csv and data/asl_trunk_compare_sep2024.csv (made by
``python -m lab compare``, commands in data/README.md and each sidecar) and checks the
claim the docs make: the recommended model, the ensemble of five Bayesian-regularised
networks, is at least as accurate -- mean test RMS 3-D distance over the splits -- as the
best of the Gaussian process and the cubic polynomial, on the random and on the group
splits of both datasets, for every history length in the files. It prints each of those
margins, the ensemble's ratio to the affine baseline on the sequential split (the ASL Trunk
authors' split: first 80 % of the rows against the last 20 %), the ratio to the
repeatability floor where a sidecar has one, and the learning curve where a file has it.
Exit code 1 if a check fails.
"""

import json
import sys
from pathlib import Path

from lab.studies.model_comparison import read_comparison

ROOT = Path(__file__).resolve().parent.parent
FILES = {"October 2024": "asl_trunk_compare_oct2024.csv", "September 2024": "asl_trunk_compare_sep2024.csv"}
RIVALS = ("gpr", "poly3")


def main() -> int:
    lines, failed = [], []

    def say(text: str = "") -> None:
        lines.append(text)
        print(text)

    for label, name in FILES.items():
        path = ROOT / "data" / name
        side = json.loads(Path(f"{path}.json").read_text())
        rows = read_comparison(path)
        summary = {(s["split"], s["history"], s["model"]): s for s in side["summary"]}
        floor = (side.get("floor") or {}).get("floor_m")
        say(f"{label}: {name}, {len(rows)} rows, {side['dataset']['n_rows']} data rows")
        for s in side["summary"]:  # in the order the command prints it
            split, k = s["split"], s["history"]
            if s["model"] != "ensemble":
                continue
            rms = s["test_rms_m"]
            extra = f", {rms / floor:.2f} x the floor {1e3 * floor:.1f} mm" if floor else ""
            if split == "sequential":
                lin = summary[(split, k, "linear")]["test_rms_m"]
                say(f"  {split:14s} K={k}: ensemble {1e3 * rms:5.1f} mm RMS = {rms / lin:.3f} x linear "
                    f"({1e3 * lin:.1f} mm){extra}")  # fmt: skip
                continue
            best = min(RIVALS, key=lambda m: summary[(split, k, m)]["test_rms_m"])
            rival = summary[(split, k, best)]["test_rms_m"]
            ok = rms <= rival
            if not ok:
                failed.append(f"{label} {split} K={k}")
            say(f"  {split:14s} K={k}: ensemble {1e3 * rms:5.1f} mm RMS over {s['n_splits']} splits, best of "
                f"gpr/poly3 {best} {1e3 * rival:5.1f} mm: ratio {rms / rival:.3f} "
                f"{'ok' if ok else 'FAILED'}{extra}")  # fmt: skip
        curve: dict = {}
        for c in side.get("learning_curve") or []:
            curve.setdefault((c["history"], c["model"]), []).append(c)
        for (k, model), cs in curve.items():
            if cs is next(iter(curve.values())):
                say(f"  learning curve (random splits), mm RMS at N = {', '.join(str(c['n_train']) for c in cs)}:")
            say(f"    K={k} {model:12s} " + " ".join(f"{1e3 * c['test_rms_m']:6.1f}" for c in cs))
    say("all checks passed" if not failed else f"FAILED: {', '.join(failed)}")
    (ROOT / "benchmarks" / "bench_real_data.txt").write_text("\n".join(lines) + "\n")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
