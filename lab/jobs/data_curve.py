"""``python -m lab data-curve``: model and tracking error against the number of samples N,
per sampling strategy.

The settings cross in one :class:`lab.studies.data_curve_spec.DataCurveSpec` (robot, rig,
strategies, counts N, seeds, trainer, capture rate, mesh). For each strategy and each N,
:func:`run` writes one row -- the model error on a common held-out set of random allowed
commands, the Table I tracking errors, the fit time and the capture hours at the measured
rate -- through :func:`lab.studies.data_curve_run.run_data_curve`
(:mod:`lab.studies.data_curve`). Rows are appended one by one, so an interrupted run
resumes where it stopped; a file is only resumed with the settings it was made with.
"""

from __future__ import annotations

from lab.studies.data_curve_spec import DataCurveSpec

__all__ = ["run"]


def run(spec: DataCurveSpec, out, *, jobs: int = 1, command: str = "", log=None) -> list[dict]:
    """Measure ``spec``'s curve, rows to ``out``.

    Parameters
    ----------
    spec : DataCurveSpec
        Robot, rig, strategies, counts, seeds, trainer and mesh.
    out : str or Path
        CSV, one row per (strategy, N, seed), with a ``.json`` sidecar; resumed if it exists.
    jobs : int
        Worker processes, one row each.
    command : str
        The command line, recorded in the sidecar.
    log : callable, optional
        Called with each progress line.

    Returns
    -------
    list of dict
        Every row of the file (errors in m, times in s, capture in hours).
    """
    from lab.studies.data_curve_run import run_data_curve

    return run_data_curve(spec, out, jobs=jobs, command=command, log=log)
