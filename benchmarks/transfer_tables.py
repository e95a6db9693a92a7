"""The sim-to-real curve's tables, as docs/results-sim-to-real.md shows them.

    python benchmarks/transfer_tables.py data/transfer_curve.csv data/transfer_curve_foam.csv

Per curve file (``python -m lab transfer-curve``): Table I tracking error (cm) and model
error (mm) per method and N as family mean (median) over the robots (the shipped robot left
out), and the smallest N at which each method's family mean reaches 0.25 cm and 0.15 cm.
"""

import sys

import numpy as np

from lab.studies.transfer_study import read_curve, smallest_n


def table(rows: list[dict], key: str, scale: float, fmt: str) -> str:
    fam = [r for r in rows if r["robot"] != "shipped"]
    ns = sorted({r["n_real"] for r in fam})
    out = ["| method | " + " | ".join(f"N = {n}" for n in ns) + " |", "|---" * (len(ns) + 1) + "|"]
    for method in dict.fromkeys(r["method"] for r in fam):
        cells = []
        for n in ns:
            v = [scale * r[key] for r in fam if r["method"] == method and r["n_real"] == n]
            cells.append(f"{np.mean(v):{fmt}} ({np.median(v):{fmt}})" if v else "–")
        out.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main() -> None:
    for path in sys.argv[1:]:
        rows = read_curve(path)
        robots = sorted({r["robot"] for r in rows if r["robot"] != "shipped"})
        print(f"## {path}: {len(robots)} robots ({robots[0]} .. {robots[-1]})\n")
        print("Table I tracking error, cm: family mean (median)\n")
        print(table(rows, "tracking_mean_m", 100.0, ".3f"))
        print("\nmodel error on the held-out random commands, mm: family mean (median)\n")
        print(table(rows, "model_error_m", 1e3, ".2f"))
        print()
        goal, real = smallest_n(rows, 0.0025), smallest_n(rows, 0.0015)
        for method in goal:
            g, r = goal[method], real[method]
            print(
                f"{method:>14}: <= 0.25 cm from N = {g[0] if g else 'never'}; "
                f"<= 0.15 cm from N = {r[0] if r else 'never'}"
            )
        print()


if __name__ == "__main__":
    main()
