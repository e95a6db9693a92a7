"""``python -m lab inspect``: what a static model can reach on a dataset, before training one.

The settings cross in one :class:`lab.data.diagnostics.InspectSpec`; :func:`run` reads the
dataset (CSV + sidecar; measured sequences from its ``sequence_starts``) and writes the
report of :func:`lab.data.diagnostics.inspect_file` -- the repeatability floor,
hysteresis, drift over the measurement order and outliers -- as JSON. What each number
means and assumes: ``docs/real-data.md``; the figure of a report:
:func:`lab.viz.real_data.plot_diagnostics`.
"""

from __future__ import annotations

from lab.data.diagnostics import InspectSpec

__all__ = ["run"]


def run(spec: InspectSpec, data, out, *, command: str | None = None, progress=None) -> dict:
    """Inspect the dataset ``data`` and write the report to ``out``.

    Parameters
    ----------
    spec : InspectSpec
        The diagnostics' settings (pairs, bootstrap, neighbours, thresholds).
    data : str or Path
        Dataset CSV (``u0..,x,y,z``; metres) with its ``.json`` sidecar.
    out : str or Path
        The report (.json).
    command : str, optional
        The command line, recorded in the report.
    progress : callable, optional
        ``progress(done, total)``: steps of the bootstrap and permutation loops done
        (``lab.data.diagnostics.PERMUTATION_STEPS``), 0 as the first starts.

    Returns
    -------
    dict
        The report (``floor``, ``hysteresis``, ``drift``, ``outliers``, sizes; lengths in m).
    """
    from lab.data.diagnostics import inspect_file

    return inspect_file(data, out, spec, command=command, progress=progress)
