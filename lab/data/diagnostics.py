"""What a static model can reach on a dataset: the diagnostics behind ``python -m lab inspect``.

Before fitting a model u -> y to measured data it pays to know what no static model can
fit. :func:`inspect_dataset` gathers four measurements on ``u`` (N, m), ``y`` (N, 3) m and
the measurement sequences: the repeatability floor and hysteresis
(:mod:`lab.data.repeatability`); drift over the measurement order (:func:`drift`: the
residual of a local fit against the row index, within sequences, and the tip difference
of near pairs against their row distance); and outliers (:func:`outliers`: rows far from a
leave-one-out local fit, beyond median + k MAD). The local fit
(:func:`lab.data.repeatability.local_residuals`) is the mean tip of the ``neighbours``
nearest rows in scaled command space. The report is a versioned JSON-ready
dict; :func:`inspect_file` reads a dataset and writes it. What each number assumes:
``docs/real-data.md``.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lab.data.repeatability import (
    MIN_PAIRS,
    hysteresis,
    local_residuals,
    neighbour_pairs,
    repeatability_floor,
    scaled_commands,
)
from lab.errors import InputError
from lab.specs import Spec, at_most, non_negative_int, option, positive, positive_int

__all__ = ["InspectSpec", "drift", "outliers", "inspect_dataset", "inspect_file"]

FORMAT_VERSION = 1
MAX_NEIGHBOURS = 50  # the local fit averages this many rows; more blurs the map itself
MAX_BOOTSTRAP = 5000  # resamples per interval (each refits on every pair)
MAX_BLOCK_ROWS = 1000  # the leave-block-out fit looks past a whole block for each row
MAX_ABS_TIP_M = 10.0  # a tip coordinate beyond this is not in metres (or not a tip)
MAX_ABS_COMMAND = 1e6  # a command beyond this, in any unit, is not a motor command
#: A robust sigma from the median absolute deviation of a Gaussian.
MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class InspectSpec(Spec):
    """The settings of :func:`inspect_dataset` (flags of ``python -m lab inspect``).

    Attributes
    ----------
    neighbours : int
        Nearest rows in scaled command space per row: the near pairs and the local fit.
    bootstrap : int
        Resamples for each 95-percent interval (and permutations of the hysteresis test).
    outlier_mads : float
        Outlier threshold: median + K robust sigmas (1.4826 MAD) of the local-fit residual.
    block_rows : int
        Drift: sequences are cut into blocks of at most this many rows.
    seed : int
        Random seed of the bootstrap, >= 0.
    """

    neighbours: int = option(
        5, type=int, check=at_most(MAX_NEIGHBOURS, positive_int),
        help="nearest rows in scaled command space per row: the near pairs and the local fit",
    )  # fmt: skip
    bootstrap: int = option(
        200, type=int, check=at_most(MAX_BOOTSTRAP, positive_int),
        help="resamples for each 95-percent interval (and permutations of the hysteresis test)",
    )  # fmt: skip
    outlier_mads: float = option(
        5.0, type=float, check=at_most(100, positive),
        help="outlier threshold: a row's local-fit residual beyond median + K robust sigmas (1.4826 MAD)",
    )  # fmt: skip
    block_rows: int = option(
        100, type=int, check=at_most(MAX_BLOCK_ROWS, positive_int),
        help="drift: sequences are cut into blocks of at most N rows, the units of the local fit and bootstrap",
    )  # fmt: skip
    seed: int = option(0, type=int, check=non_negative_int, help="random seed of the bootstrap")


def _blocks(seq: np.ndarray, block_rows: int) -> np.ndarray:
    """Block number of each row: each sequence cut into blocks of at most ``block_rows`` rows."""
    start = np.r_[0, np.flatnonzero(np.diff(seq)) + 1]
    pos = np.arange(len(seq)) - np.repeat(start, np.diff(np.r_[start, len(seq)]))
    new = (pos % block_rows == 0).astype(int)
    return np.cumsum(new) - 1


def _demean(values: np.ndarray, seq: np.ndarray) -> np.ndarray:
    _, inv = np.unique(seq, return_inverse=True)
    inv = inv.ravel()
    cols = values.reshape(len(values), -1)
    means = np.stack([np.bincount(inv, c) / np.bincount(inv) for c in cols.T], axis=1)
    return (cols - means[inv]).reshape(values.shape)


def drift(
    u_motor, p_tip_W, seq_ids, pairs, *, neighbours: int = 5, block_rows: int = 100, bootstrap: int = 200, seed: int = 0
) -> dict:
    """Drift over the measurement order (the row index stands for time, within sequences).

    The residual ``r`` of a local fit from rows outside the row's block (:func:`local_residuals`)
    holds ``v (t - t_fit)`` for a drift ``v`` (m per row), ``t`` the row index and ``t_fit``
    the mean row index of the rows the fit used; ``r`` is regressed on ``t - t_fit`` within
    each sequence (both minus their sequence mean) for the slope ``v`` (3,).

    Parameters
    ----------
    u_motor : array_like
        Commands (N, m), rad.
    p_tip_W : array_like
        Tips (N, 3), m, frame W.
    seq_ids : array_like
        Sequence number (N,) of each row, ascending.
    pairs : numpy.ndarray
        Near pairs (P, 2) of row indices (:func:`neighbour_pairs`).
    neighbours, block_rows, bootstrap, seed : int
        As in :class:`InspectSpec`.

    Returns
    -------
    dict
        ``rate_m_per_1000_rows`` = ``1000 |v|`` with a 95 % ``interval`` (bootstrap over
        blocks), ``velocity_m_per_1000_rows`` (3,);
        ``row_index_r2_from_command``: how much of the row index the commands explain
        linearly within sequences (near 1: drift and command order cannot be told apart);
        ``offset_rms_m``: RMS 3-D mean residual of the sequences (between-session offsets);
        ``pairs_gap_m2_per_1000_rows``: the rise of the squared tip difference of ``pairs``
        in one sequence per 1000 rows between them (a fit with ``d^2``), with interval;
        ``blocks`` and ``sample`` for a figure.
    """
    u, y, seq = np.asarray(u_motor, float), np.asarray(p_tip_W, float), np.asarray(seq_ids)
    n, rng = len(y), np.random.default_rng(seed)
    block = _blocks(seq, block_rows)
    single = block.max() == 0
    t = np.arange(n, dtype=float)
    res = local_residuals(u, np.column_stack([y, t]), neighbours, groups=None if single else block)
    r, ok = res[:, :3], np.all(np.isfinite(res), axis=1)
    tc, rc = _demean(res[ok, 3], seq[ok]), _demean(r[ok], seq[ok])
    out: dict = {"n_blocks": int(block.max() + 1), "fit": "leave-one-out" if single else "leave-block-out"}
    if np.sum(tc**2) > 0:
        v = tc @ rc / np.sum(tc**2)
        blk, draws = block[ok], []
        ids = np.unique(blk)
        num = np.stack([np.bincount(blk, tc * rc[:, c], minlength=blk.max() + 1) for c in range(3)], 1)[ids]
        den = np.bincount(blk, tc**2, minlength=blk.max() + 1)[ids]
        for _ in range(bootstrap):
            s = rng.integers(0, len(ids), len(ids))
            draws.append(np.linalg.norm(num[s].sum(0) / max(den[s].sum(), 1e-300)))
        uc, tr = _demean(u[ok], seq[ok]), _demean(t[ok], seq[ok])
        fit = np.linalg.lstsq(uc, tr, rcond=None)[0]
        out.update(
            rate_m_per_1000_rows=float(1000 * np.linalg.norm(v)),
            interval=[float(1000 * q) for q in np.quantile(draws, [0.025, 0.975])],
            velocity_m_per_1000_rows=[float(1000 * c) for c in v],
            row_index_r2_from_command=float(1 - np.sum((tr - uc @ fit) ** 2) / max(np.sum(tr**2), 1e-300)),
        )
    else:
        out.update(rate_m_per_1000_rows=None, reason="no sequence has two rows")
    mean_r = np.stack([np.bincount(seq[ok], r[ok, c]) / np.maximum(np.bincount(seq[ok]), 1) for c in range(3)], 1)
    present = np.bincount(seq[ok]) > 0
    out["offset_rms_m"] = float(np.sqrt(np.mean(np.sum(mean_r[present] ** 2, 1)))) if present.sum() > 1 else None
    out["blocks"] = {
        "row": [float(t[ok][block[ok] == b].mean()) for b in np.unique(block[ok])],
        "start": [int(np.flatnonzero(block == b)[0]) for b in np.unique(block[ok])],
        "stop": [int(np.flatnonzero(block == b)[-1]) + 1 for b in np.unique(block[ok])],
        "residual_m": [[float(c) for c in r[ok][block[ok] == b].mean(0)] for b in np.unique(block[ok])],
        "sequence": [int(seq[block == b][0]) for b in np.unique(block[ok])],
    }
    out.update(_pair_gaps(u, y, seq, pairs, bootstrap, rng))
    return out


def _pair_gaps(u, y, seq, pairs, bootstrap, rng) -> dict:
    """Squared tip difference of same-sequence pairs against their row gap (OLS with d^2)."""
    same = seq[pairs[:, 0]] == seq[pairs[:, 1]]
    p = pairs[same]
    z = scaled_commands(u)
    gap = (p[:, 1] - p[:, 0]) / 1000.0
    d2 = np.sum((z[p[:, 0]] - z[p[:, 1]]) ** 2, 1)
    dy2 = np.sum((y[p[:, 0]] - y[p[:, 1]]) ** 2, 1)
    x = np.column_stack([np.ones_like(gap), d2, gap])
    sample = {"gap_rows": [], "dy_m": []}
    if len(p) < MIN_PAIRS or np.linalg.matrix_rank(x) < 3:
        return {"pairs_gap_m2_per_1000_rows": None, "pairs_gap_interval": None, "pairs_sample": sample}
    slope = float(np.linalg.lstsq(x, dy2, rcond=None)[0][2])
    draws = [
        np.linalg.lstsq(x[s], dy2[s], rcond=None)[0][2]
        for s in (rng.integers(0, len(p), len(p)) for _ in range(bootstrap))
    ]
    take = rng.choice(len(p), min(len(p), 1500), replace=False)
    sample = {"gap_rows": [int(v) for v in 1000 * gap[take]], "dy_m": [float(v) for v in np.sqrt(dy2[take])]}
    return {
        "pairs_gap_m2_per_1000_rows": slope,
        "pairs_gap_interval": [float(q) for q in np.quantile(draws, [0.025, 0.975])],
        "pairs_sample": sample,
    }


def outliers(u_motor, p_tip_W, *, neighbours: int = 5, outlier_mads: float = 5.0) -> dict:
    """Rows whose leave-one-out local-fit residual (3-D norm, m) exceeds median + k * 1.4826 MAD.

    Parameters
    ----------
    u_motor : array_like
        Commands (N, m), rad.
    p_tip_W : array_like
        Tips (N, 3), m, frame W.
    neighbours : int
        Rows of each local fit.
    outlier_mads : float
        k, in robust sigmas.

    Returns
    -------
    dict
        ``count``, ``rows`` (0-based indices), ``residual_m`` (theirs), ``threshold_m``,
        ``median_m``, ``robust_sigma_m``, and ``residual_rms_m``: the RMS 3-D residual of
        that local fit over all rows (what a simple local model reaches, an upper
        reference for the floor).
    """
    r = np.linalg.norm(local_residuals(u_motor, p_tip_W, neighbours), axis=1)
    ok = np.isfinite(r)
    med = float(np.median(r[ok])) if ok.any() else 0.0
    sigma = MAD_TO_SIGMA * float(np.median(np.abs(r[ok] - med))) if ok.any() else 0.0
    threshold = med + outlier_mads * sigma
    rows = np.flatnonzero(ok & (r > threshold))
    return {
        "count": int(len(rows)),
        "rows": [int(i) for i in rows],
        "residual_m": [float(r[i]) for i in rows],
        "threshold_m": threshold,
        "median_m": med,
        "robust_sigma_m": sigma,
        "residual_rms_m": float(np.sqrt(np.mean(r[ok] ** 2))) if ok.any() else None,
    }


#: What one permutation of the hysteresis test costs in resamples of all pairs of the
#: floor's bootstrap (measured 4.6 on the 3,489-row ASL set), so that the steps
#: :func:`inspect_dataset` reports take about equal time.
PERMUTATION_STEPS = 5


def inspect_dataset(u_motor, p_tip_W, seq_ids=None, spec: InspectSpec | None = None, progress=None) -> dict:
    """All diagnostics of a dataset.

    Parameters
    ----------
    u_motor : array_like
        Commands (N, m), rad.
    p_tip_W : array_like
        Tips (N, 3), m, frame W.
    seq_ids : array_like, optional
        Sequence numbers (N,) int, ascending in row order from 0; None: one sequence.
    spec : InspectSpec, optional
        The settings; default ``InspectSpec()``.
    progress : callable, optional
        ``progress(done, total)``: steps of the bootstrap and permutation loops done of at
        most ``total`` = (2 + :data:`PERMUTATION_STEPS`) ``bootstrap`` (a resample of a share
        of the pairs counts as that share; loops without enough pairs are skipped), 0 as the
        first starts. It only observes: the report is the same without it.

    Returns
    -------
    dict
        The report, JSON-ready: ``format_version``, ``kind``, sizes, the ``spec``, and the
        sections ``floor``, ``hysteresis``, ``drift``, ``outliers`` (lengths in m);
        ``floor["cautions"]``: sentences on how far the floor was extrapolated and whether
        a local fit contradicts it.
    """
    spec = spec or InspectSpec()
    u, y = np.asarray(u_motor, float), np.asarray(p_tip_W, float)
    if u.ndim != 2 or y.shape != (len(u), 3):
        raise InputError(f"expected u (N, m) and y (N, 3), got {u.shape} and {y.shape}")
    seq = np.zeros(len(u), int) if seq_ids is None else np.asarray(seq_ids, int)
    if seq.shape != (len(u),) or np.any(np.diff(seq) < 0) or (len(seq) and seq[0] != 0):
        raise InputError("seq_ids must be (N,) sequence numbers, ascending in row order from 0")
    if len(u) < spec.neighbours + 2:
        raise InputError(
            f"{len(u)} rows: too few to inspect with InspectSpec.neighbours {spec.neighbours} (need K + 2)"
        )
    for name, a, limit in (("u", u, MAX_ABS_COMMAND), ("y", y, MAX_ABS_TIP_M)):
        bad = ~np.isfinite(a) | (np.abs(np.nan_to_num(a, nan=np.inf)) > limit)
        if bad.any():
            row, col = (int(v) for v in np.argwhere(bad)[0])
            raise InputError(
                f"{name}: row {row} (line {row + 2} of a dataset CSV), column {col} is {a[row, col]!r}: "
                f"NaN, infinite or beyond {limit:g}" + (" m (is it in metres?)" if name == "y" else "")
            )
    k, b, s = spec.neighbours, spec.bootstrap, spec.seed
    total, done = (2 + PERMUTATION_STEPS) * b, [0]

    def step(n: float = 1) -> None:
        done[0] += n
        if progress is not None:
            progress(done[0], total)

    step(0)
    pairs, _, _ = neighbour_pairs(u, k)
    report = {
        "format_version": FORMAT_VERSION,
        "kind": "lab.inspect",
        "n_rows": len(u),
        "n_motors": u.shape[1],
        "n_sequences": int(seq.max() + 1),
        "spec": spec.as_dict(),
        "floor": repeatability_floor(u, y, seq, neighbours=k, bootstrap=b, seed=s, tick=step),
        "hysteresis": hysteresis(u, y, seq, pairs, permutations=b, seed=s, tick=lambda n: step(n * PERMUTATION_STEPS)),
        "drift": drift(u, y, seq, pairs, neighbours=k, block_rows=spec.block_rows, bootstrap=b, seed=s),
        "outliers": outliers(u, y, neighbours=k, outlier_mads=spec.outlier_mads),
    }
    report["floor"]["cautions"] = _cautions(report["floor"], report["outliers"], k)
    return _json_ready(report)


def _cautions(floor: dict, out: dict, neighbours: int) -> list[str]:
    """What to keep in mind reading the floor: how far it was extrapolated, and whether it
    exceeds what a local fit already reaches (its residual holds the floor times sqrt(1 + 1/K))."""
    notes = []
    if floor["n_exact_pairs"] == 0 and floor.get("min_distance") is not None:
        d_min = floor["min_distance"]
        notes.append(f"no exact revisits: extrapolated to 0 from pairs at command distance >= {d_min:.2f}")
    reference = (out["residual_rms_m"] or 0.0) * np.sqrt(neighbours / (neighbours + 1))
    if floor.get("floor_m") is not None and floor["floor_m"] > reference:
        notes.append(
            f"above the {1e3 * reference:.1f} mm a leave-one-out local fit implies (its residual over sqrt(1 + 1/K)): "
            "the extrapolation is biased up (pairs too far apart); try more --neighbours"
        )
    return notes


def inspect_file(path, out, spec: InspectSpec | None = None, *, command: str | None = None, progress=None) -> dict:
    """Read a dataset, inspect it and write the report as JSON (atomically).

    Parameters
    ----------
    path : str or pathlib.Path
        The dataset CSV (+ sidecar; sequences from its ``sequence_starts``).
    out : str or pathlib.Path
        The report file to write.
    spec : InspectSpec, optional
        The settings; default ``InspectSpec()``.
    command : str, optional
        The command line that made the report, recorded in it.
    progress : callable, optional
        ``progress(done, total)`` as :func:`inspect_dataset` tells it.

    Returns
    -------
    dict
        The report (:func:`inspect_dataset`).
    """
    from lab.data.dataset import read_dataset
    from lab.data.sequences import sequence_ids
    from lab.files import atomic_write_text

    u, y, meta = read_dataset(path)
    seq = sequence_ids(meta, len(u), where=f"{path}.json")
    try:
        report = inspect_dataset(u, y, seq, spec, progress)
    except InputError as err:
        raise InputError(f"{path}: {err}") from None
    robot = meta.get("robot") if isinstance(meta.get("robot"), dict) else {}
    units = meta.get("units") if isinstance(meta.get("units"), dict) else {}
    report["dataset"] = {
        "path": str(path),
        # the bytes read, with or without a sidecar: compare --floor tells the data by it
        "csv_sha256": hashlib.sha256(Path(path).read_bytes()).hexdigest(),
        "robot": robot.get("name"),
        "u_unit": robot.get("u_unit") or units.get("u"),
    }
    report["command"] = command
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, json.dumps(report, indent=1, allow_nan=False) + "\n")
    return report


def _json_ready(obj):
    """``obj`` with every non-finite float (a quantity that could not be measured) as None."""
    if isinstance(obj, dict):
        return {k: _json_ready(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_ready(v) for v in obj]
    if isinstance(obj, (float, np.floating)):
        return float(obj) if np.isfinite(obj) else None
    return obj.item() if isinstance(obj, np.generic) else obj
