"""``python -m lab transfer-curve``: the sim-to-real curve over a family of emulated as-built robots.

The settings cross in one :class:`lab.studies.transfer_curve.TransferCurveSpec` (the
family's members, the shipped defects, methods, counts N, seeds, mesh, workers). For each
robot, each method and each N, :func:`run` writes one row -- model error on held-out
random commands and Table I tracking errors, in metres -- through
:func:`lab.studies.transfer_curve.transfer_curve_run` (:mod:`lab.studies.transfer_study`).
Rows are appended robot by robot, so an interrupted run resumes where it stopped; a robot
whose rows are all there is skipped.
"""

from __future__ import annotations

from lab.studies.transfer_curve import TransferCurveSpec

__all__ = ["run"]


def run(spec: TransferCurveSpec, out, *, command: str = "", log=None) -> list[dict]:
    """Measure ``spec``'s curve, rows to ``out``.

    Parameters
    ----------
    spec : TransferCurveSpec
        Robots, methods, counts, seeds, mesh and workers.
    out : str or Path
        CSV, one row per (robot, method, N), with a ``.json`` sidecar; resumed if it exists.
    command : str
        The command line, recorded in the sidecar.
    log : callable, optional
        Called with each progress line.

    Returns
    -------
    list of dict
        Every row of the file (errors in m).
    """
    from lab.studies.transfer_curve import transfer_curve_run

    return transfer_curve_run(spec, out, command=command, log=log)
