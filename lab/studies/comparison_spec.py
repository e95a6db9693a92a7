"""The settings of a model comparison (:class:`CompareSpec`), the models' recipes, and the summary.

``python -m lab compare`` fits every model of :data:`COMPARE_MODELS` on the same splits of
one dataset. This module holds what a comparison is made of, typed: which models
(``--models``), which splits (``--splits``: random rows, whole sequences, or the first
80 % in measurement order), how many (``--n-splits``), which history lengths
(``--history``), the optional learning curve (``--ns``), the test fraction and the seed.
:data:`RECIPES` says how each model is fitted (architecture, training rule, iteration
caps, the GP's subsample): it is written into the results' sidecar and a file is resumed
only with the same recipes, so rows of one file were all made the same way. The caps
(BR epochs, scikit-learn's L-BFGS iterations, the GP's restarts) keep a run over a real
dataset to tens of minutes on two cores (docs/real-data.md). :func:`summarise`
averages the rows per (split, history, model), against a repeatability floor read by
:func:`floor_of` from an ``inspect`` report of the same data.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.learn.history import MAX_HISTORY
from lab.learn.peers_gp import GP_MAX_SAMPLES
from lab.specs import Spec, at_most, non_negative_int, option, positive_int

__all__ = [
    "COMPARE_MODELS",
    "COMPARE_SPLITS",
    "CompareSpec",
    "MAX_COMPARE_SPLITS",
    "MIN_CURVE_N",
    "RECIPES",
    "SEQUENTIAL_TRAIN_FRACTION",
    "floor_of",
    "json_ready",
    "summarise",
]

#: Every model the comparison knows, in the order the summary lists them.
COMPARE_MODELS = ("linear", "poly3", "gpr", "knn", "sklearn-mlp", "mlp", "br", "ensemble")
#: random: test = a random fraction of rows; group: whole sequences (or contiguous blocks);
#: sequential: train on the first SEQUENTIAL_TRAIN_FRACTION of the rows, test on the rest.
COMPARE_SPLITS = ("random", "group", "sequential")
SEQUENTIAL_TRAIN_FRACTION = 0.8
#: Most repeats of the random and group splits (each fits every model once more).
MAX_COMPARE_SPLITS = 100
#: Fewest training rows of a learning-curve row (``--ns``).
MIN_CURVE_N = 20
#: Epoch cap of Bayesian-regularised training (br and each ensemble member), L-BFGS
#: iterations of scikit-learn's MLP, the GP's random restarts.
BR_EPOCHS, SKLEARN_MLP_ITER, GP_RESTARTS = 100, 500, 0

#: How each model is fitted (the sidecar's "recipes"; a file resumes only with the same).
RECIPES = {
    "linear": "least squares, affine in the inputs min-max scaled to [-1, 1] (lab.studies.baselines.fit_poly, 1)",
    "poly3": "least squares, every monomial of degree <= 3 of the scaled inputs (fit_poly, 3)",
    "gpr": f"lab.learn.peers.fit_gpr: ARD RBF + white noise from 1e-2, {GP_RESTARTS} restarts, a random subset "
    f"of {GP_MAX_SAMPLES} training rows where there are more",
    "knn": "lab.learn.models.fit_model('knn'): 5 nearest neighbours in the scaled inputs, inverse-distance weights",
    "sklearn-mlp": f"lab.learn.peers.fit_sklearn_mlp: MLPRegressor 20-20 tanh, L-BFGS, at most {SKLEARN_MLP_ITER} "
    "iterations",
    "mlp": "lab.learn.models.fit_model('mlp'): lab's MLP 20-20, Levenberg-Marquardt, 10 % of the training rows "
    "for early stopping",
    "br": f"fit_model('mlp', algorithm='br'): MLP 10-10, Bayesian regularisation, at most {BR_EPOCHS} epochs, "
    "all training rows",
    "ensemble": f"fit_model('ensemble', algorithm='br', members=5): 5 MLPs 10-10, Bayesian regularisation, at most "
    f"{BR_EPOCHS} epochs each; spread = the members' std (scale 1: no held-out rows to fit one)",
}


def _names(known: tuple):
    def check(v) -> str | None:
        bad = [x for x in v if x not in known]
        if not v or bad:
            return f"must be among {', '.join(known)} (unknown: {', '.join(map(str, bad)) or 'none given'})"
        return None

    return check


def _ints(low: int, high: int | None = None):
    def check(v) -> str | None:
        if not v or not all(isinstance(x, int) and not isinstance(x, bool) and x >= low for x in v):
            return f"must be integers >= {low}"
        return None if high is None or max(v) <= high else f"must be at most {high}"

    return check


def _fraction(v) -> str | None:
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and 0.01 <= v <= 0.5
    return None if ok else "must be a number from 0.01 to 0.5"


@dataclass(frozen=True)
class CompareSpec(Spec):
    """One comparison: see the module docstring and each flag's help.

    Attributes
    ----------
    models : tuple of str
        Models to fit, among :data:`COMPARE_MODELS` (each once, in the order given).
    splits : tuple of str
        Splits among :data:`COMPARE_SPLITS`: random rows, whole sequences (``group``) or the
        first 80 % in measurement order (``sequential``).
    n_splits : int
        Repeats of the random and group splits, 1 .. :data:`MAX_COMPARE_SPLITS`.
    history : tuple of int
        Past commands K in each model's inputs, 0 .. ``MAX_HISTORY``.
    ns : tuple of int or None
        Learning curve: also fit on N training rows of each random split (N >= :data:`MIN_CURVE_N`).
    test_fraction : float
        Test share of the random and group splits, 0.01 .. 0.5.
    seed : int
        Seed of the splits and the fits, >= 0.
    """

    models: tuple[str, ...] = option(COMPARE_MODELS, check=_names(COMPARE_MODELS), help="models to fit")
    splits: tuple[str, ...] = option(
        COMPARE_SPLITS, check=_names(COMPARE_SPLITS), help="random, group (whole sequences), sequential"
    )
    n_splits: int = option(
        5, type=int, check=at_most(MAX_COMPARE_SPLITS, positive_int), help="repeats of the random and group splits"
    )
    history: tuple[int, ...] = option(
        (0, 1), type=int, check=_ints(0, MAX_HISTORY), help="past commands K of each model's inputs"
    )
    ns: tuple[int, ...] | None = option(
        None,
        type=int,
        check=_ints(MIN_CURVE_N),
        help="learning curve: also fit on N rows of each random split",
    )
    test_fraction: float = option(0.1, type=float, check=_fraction, help="test share of the random and group splits")
    seed: int = option(0, type=int, check=non_negative_int, help="seed of the splits and the fits")

    def __post_init__(self):
        for name in ("models", "splits", "history", "ns"):
            v = getattr(self, name)
            if v is not None:
                object.__setattr__(self, name, tuple(dict.fromkeys(v)))  # in order, once each
        super().__post_init__()

    def settings(self) -> dict:
        """What a results file resumes with only if it was made with the same (the models,
        splits, counts, histories and ``ns`` only choose rows and may grow).

        Returns
        -------
        dict
            ``test_fraction``, ``seed`` and ``sequential_train_fraction``.
        """
        return {
            "test_fraction": self.test_fraction,
            "seed": self.seed,
            "sequential_train_fraction": SEQUENTIAL_TRAIN_FRACTION,
        }


def summarise(rows: list[dict], n_full_random: int, floor_m: float | None = None) -> tuple[list[dict], list[dict]]:
    """(summary, learning curve): per (split, history, model) the mean over splits of the
    test RMS, mean distance and fit time (m, s), with ``ratio_to_floor`` = RMS / ``floor_m``;
    per (history, model, n_train) the mean test RMS of the learning-curve rows (random
    rows trained on fewer than ``n_full_random`` rows)."""
    order = {m: i for i, m in enumerate(COMPARE_MODELS)}
    groups: dict = {}
    curve: dict = {}
    for r in rows:
        if r["split"] == "random" and r["n_train"] < n_full_random:
            curve.setdefault((r["history"], r["model"], r["n_train"]), []).append(r)
        else:
            groups.setdefault((r["split"], r["history"], r["model"]), []).append(r)

    def mean(rs, key):
        v = [r[key] for r in rs]
        return float(np.mean(v)) if v else float("nan")

    summary = []
    split_order = {s: i for i, s in enumerate(("random", "group", "group(blocks)", "sequential"))}
    by = sorted(groups.items(), key=lambda kv: (split_order.get(kv[0][0], 9), kv[0][1], order.get(kv[0][2], 99)))
    for (split, k, model), rs in by:
        rms = mean(rs, "test_rms_m")
        summary.append({
            "split": split, "history": k, "model": model, "n_splits": len(rs), "test_rms_m": rms,
            "test_mean_m": mean(rs, "test_mean_m"), "within_1sigma": mean(rs, "within_1sigma"),
            "fit_s": mean(rs, "fit_s"), "ratio_to_floor": rms / floor_m if floor_m else None,
        })  # fmt: skip
    lc = [
        {"history": k, "model": m, "n_train": n, "n_splits": len(rs), "test_rms_m": mean(rs, "test_rms_m")}
        for (k, m, n), rs in sorted(curve.items(), key=lambda kv: (kv[0][0], order.get(kv[0][1], 99), kv[0][2]))
    ]
    return summary, lc


def json_ready(obj):
    """``obj`` (dicts, lists, numbers) with every non-finite float as None, for strict JSON."""
    if isinstance(obj, dict):
        return {k: json_ready(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [json_ready(v) for v in obj]
    return None if isinstance(obj, float) and not np.isfinite(obj) else obj


def floor_of(path, data, sha: str) -> dict:
    """{"floor_m", "report", "interval_m"} of the ``inspect`` report ``path``; InputError
    unless it was made from the dataset ``data`` whose CSV hashes to ``sha``. The data are
    told by their content alone: a report of the same bytes made from another folder is
    accepted, a report of a file since changed (or one that records no hash) is not."""
    try:
        report = json.loads(Path(path).read_text())
        ds, floor_m = report["dataset"], report["floor"]["floor_m"]
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise InputError(f"floor report {path}: not a readable inspect report ({err})") from None
    if not isinstance(report, dict) or report.get("kind") != "lab.inspect" or not isinstance(ds, dict):
        raise InputError(f"floor report {path}: not an inspect report (kind {report.get('kind')!r})")
    if not ds.get("csv_sha256"):
        raise InputError(
            f"floor report {path}: the report records no hash of the data it was made from ({ds.get('path')}), so "
            f"it cannot be told to be of {data}; make its report again with `python -m lab inspect`"
        )
    if ds.get("csv_sha256") != sha:
        raise InputError(
            f"floor report {path}: the report was made from {ds.get('path')} (csv sha256 {ds.get('csv_sha256')}), "
            f"another dataset than {data} (csv sha256 {sha}), or the file changed since; make its report with "
            "`python -m lab inspect`"
        )
    if not isinstance(floor_m, (int, float)) or not np.isfinite(floor_m) or floor_m <= 0:
        raise InputError(f"floor report {path}: the report has no floor (floor_m {floor_m!r})")
    interval = report["floor"].get("interval_m")
    return {"floor_m": float(floor_m), "interval_m": interval, "report": str(path), "command": report.get("command")}
