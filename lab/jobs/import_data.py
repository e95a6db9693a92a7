"""``python -m lab import-data``: external measurements (CSV files) into a lab dataset.

The settings cross in one :class:`lab.data.import_spec.ImportSpec` (which columns are
the inputs and the positions, their units, how rows pair and where sequences start);
:func:`run` reads the files -- each alone, or FILE i with OBS i, paired row by row or on
an id column -- joins them, converts the positions to metres and writes the dataset and
its sidecar (provenance, licence, dropped rows, sequence starts) through
:func:`lab.data.importing.import_dataset`. The rules: docs/import-data.md.
"""

from __future__ import annotations

from lab.data.import_spec import ImportSpec

__all__ = ["run"]


def run(spec: ImportSpec, files, out, *, observations=(), command: str | None = None):
    """Import ``files`` (and their ``observations``) as the dataset ``out``.

    Parameters
    ----------
    spec : ImportSpec
        Columns, units, pairing and grouping of the files.
    files : sequence of str or Path
        CSV files holding the input columns (and, without ``observations``, the positions).
    out : str or Path
        Output dataset CSV (``u0..,x,y,z``; metres); its sidecar goes to ``out.json``.
    observations : sequence of str or Path
        CSV files holding the position columns: OBS i pairs with FILE i.
    command : str, optional
        The command line, recorded in the sidecar.

    Returns
    -------
    ImportResult
        Rows, sequences and groups written, rows dropped (by reason) and notes
        (:class:`lab.data.importing.ImportResult`).
    """
    from lab.data.importing import import_dataset

    return import_dataset(spec, files, out, observations=observations, command=command)
