"""Every model side by side on one dataset: the rows behind ``python -m lab compare``, resumed.

:func:`run_comparison` fits each model of a :class:`~lab.studies.comparison_spec.CompareSpec`
(least-squares baselines, scikit-learn peers, lab's networks) with each history length K
(inputs [u_t, ..., u_{t-K}] within a sequence, :func:`lab.learn.history.history_features`)
on the same splits -- random rows, whole sequences (:func:`lab.learn.split.divide_groups`;
a dataset of fewer than three sequences is cut into contiguous blocks, ``group(blocks)``),
and the first 80 % of rows in measurement order against the rest (``sequential``, one
split) -- and writes one row per fit: the test errors as 3-D distances (RMS, mean, median,
max; m), for models with a spread the share of test coordinates within 1 and 2 sigma
(:func:`lab.learn.spread_calibration.calibration`), the fit time. ``--ns`` adds learning-curve rows:
the same random splits, trained on N of their training rows. Rows are appended one at a
time and the CSV and its sidecar (with the summary,
:func:`lab.studies.comparison_spec.summarise`) rewritten atomically, so a run stopped in
any way resumes where it stopped; a row in the file is never fitted again, and a file
made from other data or with other settings is refused, naming them.
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import read_resumable_rows
from lab.studies.comparison_spec import (
    BR_EPOCHS,
    COMPARE_MODELS,
    GP_RESTARTS,
    RECIPES,
    SEQUENTIAL_TRAIN_FRACTION,
    SKLEARN_MLP_ITER,
    CompareSpec,
    floor_of,
    json_ready,
    summarise,
)

__all__ = ["COMPARE_COLUMNS", "fit_named", "measure_row", "read_comparison", "run_comparison", "split_rows"]

COMPARE_COLUMNS = (
    "dataset", "model", "history", "split", "split_index", "seed", "n_train", "n_test", "test_rms_m", "test_mean_m",
    "test_median_m", "test_max_m", "within_1sigma", "within_2sigma", "fit_s",
)  # fmt: skip
_TEXT, _INT = ("dataset", "model", "split"), ("history", "split_index", "seed", "n_train", "n_test")


def fit_named(name: str, u, y, seed: int):
    """Fit a comparison model.

    Parameters
    ----------
    name : str
        One of :data:`RECIPES`.
    u : array_like, shape (N, n_x)
        Inputs (commands, rad, with their history where the model takes it).
    y : array_like, shape (N, 3)
        Tips (m).
    seed : int
        Seed of the fit.

    Returns
    -------
    model
        The fitted model (``predict(u)`` -> y, m).
    """
    from lab.learn.model_specs import EnsembleSpec, NetworkSpec, model_spec
    from lab.learn.models import fit_model
    from lab.learn.peers import fit_gpr, fit_sklearn_mlp
    from lab.studies.baselines import fit_poly

    if name in ("linear", "poly3"):
        return fit_poly(u, y, 1 if name == "linear" else 3)
    if name == "gpr":
        return fit_gpr(u, y, seed, n_restarts=GP_RESTARTS, subsample=True)
    if name == "sklearn-mlp":
        return fit_sklearn_mlp(u, y, hidden=(20, 20), seed=seed, max_iter=SKLEARN_MLP_ITER)
    if name in ("knn", "mlp"):
        return fit_model(model_spec(name, seed=seed), u, y)
    br = {"hidden": (10, 10), "algorithm": "br", "epochs": BR_EPOCHS, "seed": seed}
    return fit_model(EnsembleSpec(members=5, **br) if name == "ensemble" else NetworkSpec(**br), u, y)


def split_rows(kind: str, index: int, seed: int, n: int, seq_ids, fraction: float):
    """(label, train (n_train,), test (n_test,)) row indices of split ``kind`` number ``index``."""
    from lab.learn.split import divide, split_groups

    if kind == "sequential":  # the ASL Trunk authors' split
        from lab.studies.authors_baseline import sequential_split

        return ("sequential", *sequential_split(n, SEQUENTIAL_TRAIN_FRACTION))
    groups, what = (None, "") if kind == "random" else split_groups(seq_ids)
    s = divide(n, (1.0 - fraction, 0.0, fraction), seed, groups)
    label = kind if what in ("", "sequences") else "group(blocks)"
    return label, s.train, s.test


def measure_row(data: dict, task: tuple) -> dict:
    """One row: ``task`` = (model, K, split kind, index, seed, N or None) on ``data``
    ({"u", "y", "seq", "name", "fraction"}); runs here or in a worker process."""
    from lab.learn.history import history_features
    from lab.learn.spread_calibration import calibration
    from lab.workers import watch_parent

    watch_parent()
    name, k, kind, index, seed, n_sub = task
    u, y = data["u"], data["y"]
    x = history_features(u, data["seq"], k)
    label, train, test = split_rows(kind, index, seed, len(u), data["seq"], data["fraction"])
    if n_sub is not None:
        train = np.sort(np.random.default_rng([seed, n_sub]).choice(train, n_sub, replace=False))
    t0 = time.perf_counter()
    model = fit_named(name, x[train], y[train], seed)
    fit_s = time.perf_counter() - t0
    if hasattr(model, "predict_with_std"):
        mean, std = model.predict_with_std(x[test])
        cal = calibration(y[test], mean, std)
    else:
        mean, cal = model.predict(x[test]), {"within_1sigma": float("nan"), "within_2sigma": float("nan")}
    d = np.linalg.norm(mean - y[test], axis=1)
    return {
        "dataset": data["name"], "model": name, "history": k, "split": label, "split_index": index, "seed": seed,
        "n_train": len(train), "n_test": len(test), "test_rms_m": float(np.sqrt(np.mean(d * d))),
        "test_mean_m": float(np.mean(d)), "test_median_m": float(np.median(d)), "test_max_m": float(np.max(d)),
        "within_1sigma": cal["within_1sigma"], "within_2sigma": cal["within_2sigma"], "fit_s": fit_s,
    }  # fmt: skip


def _parse(path: Path, line: int, column: str, value: str):
    if column in _TEXT:
        return value
    try:
        return int(value) if column in _INT else float(value)
    except ValueError:
        raise InputError(
            f"{path}: line {line}: {column} {value!r} is not a number; repair the file or choose another output file"
        ) from None


def _read(path: Path) -> tuple[list[dict], dict]:
    """The rows of ``path`` (typed) and its sidecar ({} if there is no file)."""
    if not path.exists():
        return [], {}
    raw = read_resumable_rows(path, COMPARE_COLUMNS, "compare")
    rows = [{c: _parse(path, i + 2, c, r[c]) for c in COMPARE_COLUMNS} for i, r in enumerate(raw)]
    side = Path(f"{path}.json")
    try:
        meta = json.loads(side.read_text())
    except (OSError, ValueError) as err:
        raise InputError(
            f"{side}: the sidecar of {path} cannot be read ({err}); its settings are unknown: choose another "
            "output file"
        ) from None
    if not isinstance(meta, dict) or not isinstance(meta.get("settings"), dict):
        raise InputError(
            f"{side}: the sidecar of {path} must be a JSON object with settings; choose another output file"
        )
    return rows, meta


def read_comparison(path) -> list[dict]:
    """The rows of a ``compare`` CSV, numbers typed.

    Parameters
    ----------
    path : str or Path
        The CSV written by :func:`run_comparison` (its sidecar ``PATH.json`` must be readable).

    Returns
    -------
    list of dict
        Rows of ``COMPARE_COLUMNS``: ints for history, split_index, seed, n_train, n_test;
        errors as float (m), ``fit_s`` (s); dataset, model, split as str.
    """
    return _read(Path(path))[0]


def _check_same(out: Path, old: dict, new: dict) -> None:
    """Refuse a file made with other settings, naming each with both values."""
    diff = [f"{k} {json.dumps(old.get(k))} (this run: {json.dumps(v)})" for k, v in new.items() if old.get(k) != v]
    if diff:
        raise InputError(f"{out} was made with other settings: {'; '.join(diff)}; choose another output file")


def _write(out: Path, rows: list[dict], meta: dict, n_full: int, floor_m) -> None:
    from lab.files import atomic_write_group

    meta["summary"], meta["learning_curve"] = summarise(rows, n_full, floor_m)
    text = [",".join(COMPARE_COLUMNS)] + [",".join(str(r[c]) for c in COMPARE_COLUMNS) for r in rows]
    side = json.dumps(json_ready(meta), indent=1, allow_nan=False) + "\n"
    atomic_write_group({Path(f"{out}.json"): side, out: "\n".join(text) + "\n"})


def run_comparison(spec: CompareSpec, data, out, *, floor=None, jobs: int = 1, command: str = "", log=None,
                   progress=None) -> dict:  # fmt: skip
    """Fit the rows of ``spec`` on the dataset ``data`` that the CSV ``out`` lacks, rewriting
    ``out`` and ``out.json`` after each row. InputError for bad data, flags or files.

    Parameters
    ----------
    spec : CompareSpec
        The comparison.
    data : str or Path
        The dataset CSV (with its sidecar).
    out : str or Path
        The results CSV (read first and resumed; its sidecar is ``out.json``).
    floor : str or Path, optional
        An ``inspect`` report of the same data (None: keep the floor of an earlier run).
    jobs : int, optional
        Worker processes (1: fit in this process).
    command : str, optional
        The command line recorded in the sidecar.
    log : callable, optional
        ``log(line)`` is told the plan and each row.
    progress : callable, optional
        ``progress(done, total)``: 0 as the first fit starts, then after each row of the
        ``total`` fits this run makes.

    Returns
    -------
    dict
        The sidecar: dataset, settings, ``floor``, ``summary`` and ``learning_curve``
        (:func:`lab.studies.comparison_spec.summarise`; errors in m, times in s).
    """
    from lab.data.dataset import read_dataset
    from lab.data.sequences import sequence_ids
    from lab.files import code_version
    from lab.learn.history import check_history_fits
    from lab.learn.split import check_enough_data
    from lab.learn.studies import run_seeds

    log = log or (lambda line: None)
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InputError(f"jobs (worker processes) must be a positive integer, got {jobs!r}")
    data, out = Path(data), Path(out)
    u, y, meta = read_dataset(data)
    seq = sequence_ids(meta, len(u), where=f"{data}.json")
    sha = hashlib.sha256(data.read_bytes()).hexdigest()
    check_enough_data(u, (1.0 - spec.test_fraction, 0.0, spec.test_fraction))
    check_history_fits(spec, max(spec.history), seq, data)  # train's and splits' rule
    n_full = len(u) - int(round(spec.test_fraction * len(u)))
    if spec.ns and max(spec.ns) >= n_full:
        raise spec.field_error(
            f"{spec.name_of('ns')} {max(spec.ns)}: a learning-curve N must be below the {n_full} training rows of a "
            "split",
            "ns",
        )
    settings = {"data_csv_sha256": sha, **spec.settings(), "recipes": {m: RECIPES[m] for m in COMPARE_MODELS}}
    rows, old = _read(out)
    if rows:
        _check_same(out, old["settings"], settings)
    # the floor of an earlier run is kept unless --floor names one
    floor_info = floor_of(floor, data.resolve(), sha) if floor is not None else (old.get("floor") if rows else None)
    seeds = run_seeds(spec.seed, spec.n_splits)
    sizes = {"random": (None, *spec.ns) if spec.ns else (None,)}
    plan = [
        (m, k, kind, i, seed if kind != "sequential" else spec.seed, n)
        for kind in spec.splits
        for i, seed in (enumerate(seeds) if kind != "sequential" else [(0, spec.seed)])
        for n in sizes.get(kind, (None,))
        for k in spec.history
        for m in spec.models
    ]
    payload = {"u": u, "y": y, "seq": seq, "name": data.name, "fraction": spec.test_fraction}
    # every split's training size, which names its rows in the file (and refuses an
    # impossible split now, not after an hour of fits)
    n_train = {(t[2], t[3]): len(split_rows(t[2], t[3], t[4], len(u), seq, spec.test_fraction)[1]) for t in plan}
    have = {(r["model"], r["history"], r["split"].split("(")[0], r["split_index"], r["n_train"]) for r in rows}
    todo = [t for t in plan if (*t[:4], t[5] or n_train[t[2], t[3]]) not in have]
    log(f"{len(todo)} fits to run, {len(rows)} rows already in {out}")
    commands = old.get("commands", []) if rows else []
    side = {
        "kind": "lab.model_comparison", "format_version": 1,
        "dataset": {"path": str(data), "csv_sha256": sha, "n_rows": len(u), "n_sequences": int(seq[-1]) + 1,
                    "robot": (meta.get("robot") or {}).get("name") if isinstance(meta.get("robot"), dict) else None},
        "settings": settings, "floor": floor_info, "command": command,
        "commands": commands + ([command] if command and command not in commands else []),
        "code_version": code_version(), "units": {"*_m": "m", "fit_s": "s", "within_*": "share of test coordinates"},
    }  # fmt: skip
    floor_m = floor_info["floor_m"] if floor_info else None
    tell = progress or (lambda done, total: None)
    tell(0, len(todo))
    _collect(_results(payload, todo, jobs), rows, out, side, n_full, floor_m, log, lambda done: tell(done, len(todo)))
    return side


def _results(payload: dict, todo: list, jobs: int):
    if jobs == 1 or len(todo) <= 1:
        yield from (measure_row(payload, t) for t in todo)
        return
    from joblib import Parallel, delayed

    from lab.workers import kill_local_workers, worker_config

    try:
        with worker_config():
            runner = Parallel(n_jobs=min(jobs, len(todo)), return_as="generator_unordered")
            yield from runner(delayed(measure_row)(payload, t) for t in todo)
    except BaseException:  # Ctrl-C, SIGTERM: stop the workers
        kill_local_workers()
        raise


def _collect(results, rows: list[dict], out: Path, side: dict, n_full: int, floor_m, log, tell) -> None:
    for done, row in enumerate(results, 1):
        rows.append(row)
        _write(out, rows, side, n_full, floor_m)
        tell(done)
        log(f"{row['split']} #{row['split_index']} K={row['history']} {row['model']} (N={row['n_train']}): "
            f"test RMS {1e3 * row['test_rms_m']:.1f} mm, fit {row['fit_s']:.1f} s")  # fmt: skip
    _write(out, rows, side, n_full, floor_m)
