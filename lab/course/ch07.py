"""Graders of chapter 07 (how big should the network be? Figure 6).

One checker per exercise. Each draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched), runs the student's
function and ``lab``'s own implementation on them, and shows one result through
:func:`lab.course.grade`:

- :func:`check_mean_test_distance` (exercise 7.1, one width of Figure 6: a repeated-split
  study by hand) against :func:`lab.learn.size_sweep`, on random 60-sample subsets of the
  chapter's data with a few epochs, so it is quick;
- :func:`check_median_and_quartiles` (exercise 7.2, the median and quartiles per width)
  against :func:`lab.learn.summarize`, on random shuffled sweeps and on the chapter's own.

The references live here, out of the student's sight: a grader cell only calls its checker.
"""

from __future__ import annotations

import numpy as np

from lab.course.grading import Grade, grade
from lab.learn import size_sweep, summarize

__all__ = ["check_mean_test_distance", "check_median_and_quartiles"]


def _one_width_by_lab(u_rad, y_m, width, n_runs, seed, epochs):
    rows = size_sweep(u_rad, y_m, [width], n_runs=n_runs, seed=seed, epochs=epochs)
    return float(np.mean([r["test_mean_distance_m"] for r in rows]))


def check_mean_test_distance(
    mean_test_distance, u_data, y_data, *, case: int | None = None, show: bool = True
) -> Grade:
    """Exercise 7.1: ``mean_test_distance(u (N, 3) rad, y (N, 3) m, width, n_runs, seed,
    epochs) -> m`` on three random 60-sample subsets of ``u_data``, ``y_data``, widths 2-5,
    2-3 runs, random seeds, 5 epochs."""
    rng = np.random.default_rng(71)
    u_data, y_data = np.asarray(u_data, float), np.asarray(y_data, float)
    cases = []
    for _ in range(3):
        pick = rng.choice(len(u_data), 60, replace=False)
        width, runs, seed = (int(rng.integers(a, b)) for a, b in ((2, 6), (2, 4), (0, 1000)))
        cases.append((u_data[pick], y_data[pick], width, runs, seed, 5))
    return grade(
        "one width of Figure 6",
        mean_test_distance,
        _one_width_by_lab,
        cases,
        rtol=1e-9,
        atol=1e-12,
        hint="one training per run, each with its own seed from run_seeds; measure each run on its own test "
        "set only, as a distance (not squared), then average over the runs",
        show=show,
        case=case,
        checker=check_mean_test_distance,
    )


def _quartiles_by_lab(width, distance_m):
    runs = [{"width": w, "d": d} for w, d in zip(width, distance_m)]
    stats = sorted(summarize(runs, "width", "d"), key=lambda s: s["width"])
    return tuple(np.array([s[k] for s in stats], dtype=float) for k in ("width", "median", "q25", "q75"))


def check_median_and_quartiles(median_and_quartiles, sweeps, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 7.2: ``median_and_quartiles(width (N,), distance (N,) m) -> (widths (K,),
    median (K,), q25 (K,), q75 (K,))`` on five random sweeps (shuffled runs, 1-10 per width)
    and on each of ``sweeps`` (lists of ``size_sweep`` rows: ``width``,
    ``test_mean_distance_m``)."""
    rng = np.random.default_rng(72)
    cases = []
    for _ in range(5):
        widths = rng.choice(np.arange(2, 80), int(rng.integers(1, 8)), replace=False)
        width = np.repeat(widths, rng.integers(1, 11, len(widths)))
        cases.append((rng.permutation(width), 1e-3 * rng.lognormal(0, 1, len(width))))
    cases += [([r["width"] for r in rows], [r["test_mean_distance_m"] for r in rows]) for rows in sweeps]
    return grade(
        "the median and the quartiles per width",
        median_and_quartiles,
        _quartiles_by_lab,
        cases,
        hint="group the runs by width, widths in increasing order; the runs of one width are not sorted, and "
        "a quartile falls between two runs unless the count is just right",
        show=show,
        case=case,
        checker=check_median_and_quartiles,
    )
