"""Studies of the learned model's accuracy: repeated random splits and network size.

Each run is independent and seeded, optionally on joblib/loky workers with one BLAS
thread each; results do not depend on the number of workers:

* :func:`evaluate_splits` -- the paper's Section V-A.3 test: train the same architecture
  on ``n_splits`` random splits (90/10 train/test) and report each test error;
* :func:`size_sweep` -- Section VI-A / Figure 6: two hidden layers of ``width`` neurons,
  ``n_runs`` random 80/10/10 splits per width. Run ``r`` uses the same split for every
  width, so the widths are compared on the same data.

Metrics are in :mod:`lab.learn.metrics`.
"""

from __future__ import annotations

import csv
import io

import numpy as np

from lab.files import atomic_write_text
from lab.learn.split import check_enough_data
from lab.workers import kill_local_workers, watch_parent


def run_seeds(seed: int, n: int) -> list[int]:
    """``n`` independent integer seeds derived from ``seed`` (NumPy SeedSequence).

    Parameters
    ----------
    seed : int
        The study's seed.
    n : int
        Seeds wanted.

    Returns
    -------
    list of int
        ``n`` seeds, the same for the same ``seed``.
    """
    return [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(n)]


def _one_run(u, y, hidden, ratios, seed, train_kwargs) -> dict:
    from lab.learn.train import train

    watch_parent()  # a worker exits once its run is gone (kill -9)
    res = train(u, y, hidden, ratios=ratios, seed=seed, **train_kwargs)
    row = {
        "hidden": "-".join(map(str, hidden)),
        "n_params": res.model.n_params,
        "seed": seed,
        "epochs": res.log.epochs,
        "best_epoch": res.log.best_epoch,
        "stop_reason": res.log.stop_reason,
        "wall_s": res.log.wall_s,
    }
    for name, err in res.errors.items():
        row[f"{name}_n"] = err["n"]
        row[f"{name}_mse_m2"] = err["mse_m2"] if err["n"] else float("nan")
        row[f"{name}_mean_distance_m"] = err["mean_distance_m"] if err["n"] else float("nan")
    return row


def run_jobs(function, jobs: list, n_jobs: int, progress=None) -> list:
    """``function(*job)`` for every job, in order, here (``n_jobs`` 1) or on ``n_jobs``
    joblib workers (one BLAS thread each); the workers are stopped on Ctrl-C or SIGTERM.

    Parameters
    ----------
    function : callable
        Runs one job; a module-level function (workers import it).
    jobs : list of tuple
        The arguments of each call.
    n_jobs : int
        Worker processes.
    progress : callable, optional
        ``progress(done, total)`` after each finished job (results come back in order, so a
        job done before an earlier one is told when the earlier one is).

    Returns
    -------
    list
        The results, in the order of ``jobs``.
    """
    tell = progress or (lambda done, total: None)
    if n_jobs == 1:
        out = []
        for job in jobs:
            out.append(function(*job))
            tell(len(out), len(jobs))
        return out
    from joblib import Parallel, delayed

    from lab.workers import worker_config

    try:
        with worker_config():
            out = []
            for row in Parallel(n_jobs=n_jobs, return_as="generator")(delayed(function)(*job) for job in jobs):
                out.append(row)
                tell(len(out), len(jobs))
            return out
    except BaseException:  # Ctrl-C, SIGTERM (lab.cli): stop the workers, do not leave them training
        kill_local_workers()
        raise


def _run_all(jobs, n_jobs: int, progress=None) -> list[dict]:
    return run_jobs(_one_run, jobs, n_jobs, progress)


def evaluate_splits(
    u, y, hidden=(20, 20), *, n_splits: int = 10, ratios=(0.9, 0.0, 0.1), seed: int = 0, n_jobs: int = 1,
    on_split=None, **train_kwargs
) -> list[dict]:  # fmt: skip
    """Train ``hidden`` on ``n_splits`` random splits; one row per split with its errors.

    Row keys: hidden, n_params, seed, epochs, best_epoch, stop_reason, wall_s and, for each
    of train/validation/test, ``{set}_n``, ``{set}_mse_m2``, ``{set}_mean_distance_m``
    (NaN for an empty set). ``train_kwargs`` go to :func:`lab.learn.train.train`.

    Parameters
    ----------
    u : array_like
        Commands, shape (N, n_u), rad.
    y : array_like
        Tips, shape (N, n_y), m.
    hidden : tuple of int
        Hidden layer widths.
    n_splits : int
        Random splits.
    ratios : tuple of float
        (train, validation, test).
    seed : int
        The study's seed (:func:`run_seeds`).
    n_jobs : int
        Worker processes.
    on_split : callable, optional
        ``on_split(done, n_splits)`` as splits finish (:func:`run_jobs`).
    **train_kwargs
        Passed to :func:`lab.learn.train.train`.

    Returns
    -------
    list of dict
        One row per split, errors in m^2 and m, ``wall_s`` in s.
    """
    check_enough_data(u, ratios)  # before any worker starts
    jobs = [(u, y, tuple(hidden), ratios, s, train_kwargs) for s in run_seeds(seed, n_splits)]
    rows = _run_all(jobs, n_jobs, on_split)
    for i, row in enumerate(rows):
        row["split"] = i
    return rows


def size_sweep(
    u,
    y,
    widths,
    *,
    n_layers: int = 2,
    n_runs: int = 10,
    ratios=(0.8, 0.1, 0.1),
    seed: int = 0,
    n_jobs: int = 1,
    **train_kwargs,
) -> list[dict]:
    """Figure 6: ``n_layers`` hidden layers of each width, ``n_runs`` splits each; one row per
    (width, run) with the keys of :func:`evaluate_splits` plus ``width`` and ``run``.

    Parameters
    ----------
    u : array_like
        Commands, shape (N, n_u), rad.
    y : array_like
        Tips, shape (N, n_y), m.
    widths : sequence of int
        Hidden layer widths to sweep.
    n_layers : int
        Hidden layers of each network.
    n_runs : int
        Random splits per width.
    ratios : tuple of float
        (train, validation, test).
    seed : int
        The study's seed (the same splits for every width).
    n_jobs : int
        Worker processes.
    **train_kwargs
        Passed to :func:`lab.learn.train.train`.

    Returns
    -------
    list of dict
        One row per (width, run), in the order of ``widths``.
    """
    check_enough_data(u, ratios)  # before any worker starts
    seeds = run_seeds(seed, n_runs)
    jobs = [(u, y, (int(w),) * n_layers, ratios, s, train_kwargs) for w in widths for s in seeds]
    # Largest networks first: the slowest jobs do not end up alone at the tail.
    order = sorted(range(len(jobs)), key=lambda i: -jobs[i][2][0])
    done = dict(zip(order, _run_all([jobs[i] for i in order], n_jobs)))
    rows = [done[i] for i in range(len(jobs))]
    for i, row in enumerate(rows):
        row["width"], row["run"] = int(widths[i // n_runs]), i % n_runs
    return rows


def summarize(rows: list[dict], by: str, value: str) -> list[dict]:
    """Per value of ``by`` (in order of first appearance): n, mean, std (ddof=1), median,
    q25 and q75 (the quartiles, NumPy's default linear interpolation: the interquartile
    range is q75 - q25), min, max of ``value`` (NaNs dropped).

    Parameters
    ----------
    rows : list of dict
        Rows of a study.
    by : str
        The key to group by (e.g. ``"width"``).
    value : str
        The key summarised (e.g. ``"test_mean_distance_m"``), in its unit.

    Returns
    -------
    list of dict
        One row per group: ``by``, ``n`` and the statistics, in the unit of ``value``.
    """
    out = []
    for key in dict.fromkeys(r[by] for r in rows):
        v = np.array([r[value] for r in rows if r[by] == key], dtype=float)
        v = v[np.isfinite(v)]
        out.append(
            {
                by: key,
                "n": len(v),
                "mean": float(v.mean()) if len(v) else float("nan"),
                "std": float(v.std(ddof=1)) if len(v) > 1 else float("nan"),
                "median": float(np.median(v)) if len(v) else float("nan"),
                "q25": float(np.percentile(v, 25)) if len(v) else float("nan"),
                "q75": float(np.percentile(v, 75)) if len(v) else float("nan"),
                "min": float(v.min()) if len(v) else float("nan"),
                "max": float(v.max()) if len(v) else float("nan"),
            }
        )
    return out


def write_csv(path, rows: list[dict], columns: list[str] | None = None) -> None:
    """Write dict rows as CSV (atomic); floats with full precision (repr).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    rows : list of dict
        The rows.
    columns : list of str, optional
        The columns, in order (default: the first row's keys).
    """
    columns = columns or list(rows[0])
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    for r in rows:
        writer.writerow([repr(float(r[c])) if isinstance(r[c], (float, np.floating)) else r[c] for c in columns])
    atomic_write_text(path, buf.getvalue())
