"""``python -m lab splits``: the ten-split accuracy study (Section V-A.3) of a model on a dataset file.

:class:`SplitsSpec` is the study's own setting (the number of random splits); the model is
a :class:`lab.learn.train_spec.TrainSpec`. :func:`run` reads the dataset
(:func:`lab.learn.run_inputs.read_all`), turns it into the model's inputs and split groups
(history features, ``group`` splits: :func:`lab.learn.run_inputs.inputs_and_groups`),
checks the network against the memory of the workers running at once, and runs
:func:`lab.learn.models.evaluate_model_splits`: the splits are those of ``mlp`` for the
same seed (the same test indices), so the rows of two models pair up split by split.
"""

from __future__ import annotations

from dataclasses import dataclass

from lab.learn.train_spec import TrainSpec
from lab.specs import Spec, option, positive_int

__all__ = ["SplitsSpec", "run", "split_warnings"]


@dataclass(frozen=True)
class SplitsSpec(Spec):
    """The ``splits`` study: how many random splits.

    Parameters
    ----------
    n_splits : int
        Number of random splits (each trains one model and reports its test errors).
    """

    n_splits: int = option(10, type=int, check=positive_int, help="number of random splits")


def run(spec: TrainSpec, splits: SplitsSpec, data, *, forward=None, command: str = "", log=None, progress=None):
    """The ten-split study of ``spec``'s model on the dataset file ``data``.

    Parameters
    ----------
    spec : TrainSpec
        The model, its training, the split ratios and kind, the seed the split seeds are
        derived from, and the worker processes (one split each).
    splits : SplitsSpec
        How many splits.
    data : str or Path
        Dataset CSV (``u0..,x,y,z``; metres) with its ``.json`` sidecar.
    forward : str or Path, optional
        A forward model file judging a direct inverse's commands (``model="inverse-mlp"``).
    command : str
        The command line, recorded in every row.
    log : callable, optional
        Called with each progress line.
    progress : callable, optional
        ``progress(done, n_splits)``: called with 0 as the first split starts, then as
        splits finish (in split order).

    Returns
    -------
    rows : list of dict
        One row per split (:func:`lab.learn.models.evaluate_model_splits` keys, with the
        history and split keys and ``command``).
    workspace_size_m : float
        Bounding-box diagonal of the tip data, m.
    """
    from lab.learn.metrics import workspace_size_m
    from lab.learn.models import evaluate_model_splits
    from lab.learn.run_inputs import forward_model, inputs_and_groups, read_all

    u, y, _, _, ids = read_all(data, ())
    x, groups, split_info = inputs_and_groups(spec, u, ids, data, log)
    forward_net = forward_model(spec, forward)
    spec, choice = spec.resolved(x.shape[1], y.shape[1], len(u))  # auto: lm or lm-subsample by size
    # spec.jobs workers run one split each; an ensemble's members train one after another there
    spec.replace(jobs=1).check_fits(x.shape[1], y.shape[1], len(u), copies=min(spec.jobs, splits.n_splits))
    if log is not None:
        net = "-".join(map(str, [x.shape[1], *spec.hidden, y.shape[1]]))
        how = f"{spec.algorithm}{f', {choice}' if choice else ''}"
        what = {
            "mlp": f"{net} network ({how})",
            "ensemble": f"{spec.members} x {net} ensemble ({how})",
        }
        past = f", history {spec.history}" if spec.history else ""
        log(
            f"{data}: {len(u)} samples; {splits.n_splits} {spec.split} splits {list(spec.ratios)} of a "
            f"{what.get(spec.model, spec.model)}{past}, seed {spec.seed}, {spec.jobs} worker(s)"
        )
    if progress is not None:
        progress(0, splits.n_splits)
    rows = evaluate_model_splits(x, y, spec.replace(jobs=1).model_spec(), n_splits=splits.n_splits,
                                 ratios=tuple(spec.ratios), seed=spec.seed, n_jobs=spec.jobs, forward=forward_net,
                                 groups=groups, on_split=progress)  # fmt: skip
    for r in rows:
        r.update(split_info, command=command)
    if groups is not None and log is not None:  # whole sequences of unequal length may leave training a sliver
        for note in split_warnings(rows, len(u), spec.ratios):
            log(f"warning: {note}")
    return rows, workspace_size_m(y)


def split_warnings(rows: list[dict], n_rows: int, ratios) -> list[str]:
    """One warning per split of ``rows`` whose training set is a sliver of the ``n_rows``
    (:func:`lab.learn.split.thin_training_note`, each naming its split).

    Parameters
    ----------
    rows : list of dict
        The study's rows (``split``, ``train_n``).
    n_rows : int
        Rows of the dataset.
    ratios : sequence of float
        (train, validation, test).

    Returns
    -------
    list of str
        The warnings, in split order; empty when every split trains on enough rows.
    """
    from lab.learn.split import thin_training_note

    notes = [(r["split"], thin_training_note(int(r["train_n"]), n_rows, ratios)) for r in rows]
    return [f"split {i}: {note}" for i, note in notes if note]
