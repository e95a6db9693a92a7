"""``python -m lab compare``: every model side by side on one dataset, one resumable run.

The settings cross in one :class:`lab.studies.comparison_spec.CompareSpec` (models,
history lengths, splits, seeds); :func:`run` fits the least-squares baselines, the
scikit-learn peers and lab's networks on the same random, group and sequential splits of
the dataset and appends one row per fit to the output
(:func:`lab.studies.model_comparison.run_comparison`): an interrupted run resumes where it
stopped, and a file made from other data or with other settings is refused. An
``inspect`` report of the same data adds each model's ratio to the repeatability floor.
"""

from __future__ import annotations

from lab.studies.comparison_spec import CompareSpec

__all__ = ["run"]


def run(spec: CompareSpec, data, out, *, floor=None, jobs: int = 1, command: str = "", log=None,
        progress=None) -> dict:  # fmt: skip
    """Compare ``spec``'s models on the dataset ``data``, rows to ``out``.

    Parameters
    ----------
    spec : CompareSpec
        Models, history lengths, splits and seeds.
    data : str or Path
        Dataset CSV (``u0..,x,y,z``; metres) with its ``.json`` sidecar.
    out : str or Path
        CSV, one row per fit (with a ``.json`` sidecar); resumed if it exists.
    floor : str or Path, optional
        An ``inspect`` report of ``data``: adds the ratio to its repeatability floor.
    jobs : int
        Worker processes, one fit each.
    command : str
        The command line, recorded in the sidecar.
    log : callable, optional
        Called with each progress line.
    progress : callable, optional
        ``progress(done, total)``: fits done of this run's ``total`` (0 as the first starts).

    Returns
    -------
    dict
        The sidecar: settings, the summary per split, history and model (test RMS in m),
        the floor and any learning curve.
    """
    from lab.studies.model_comparison import run_comparison

    return run_comparison(spec, data, out, floor=floor, jobs=jobs, command=command, log=log, progress=progress)
