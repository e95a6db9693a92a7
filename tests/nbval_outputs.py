"""nbval's check of a chapter's headline numbers, made on the chapter's one run.

``tests/test_nbval.py`` used to run each chapter a second time under nbval (``pytest
--nbval-lax``). nbval executes the cells in order in one kernel; a cell that raises fails;
a cell whose options say ``check`` (the ``nbval-check-output`` tag, or the
``# NBVAL_CHECK_OUTPUT`` comment) has the outputs the kernel sent compared with the ones
stored in the notebook, after the substitutions of the sanitize file; a cell stored with
outputs but no execution count fails. The same is done here on the messages the kernel sent
during the chapter's run (``tests/chapter_run.py``), with nbval's own functions for the
cell options, the merging of streams and the comparison. Only the collection of the
messages is nbval's loop restated (:func:`nbval_output`). A chapter with a cell nbval
would skip or let raise (``nbval-skip``, ``raises-exception``) cannot share the run: its
check runs nbval itself, as before (:func:`shares_run`).
"""

from __future__ import annotations

import re
from collections import defaultdict

from nbformat import NotebookNode
from nbval.plugin import (
    IPyNbCell,
    coalesce_streams,
    find_comment_markers,
    find_metadata_tags,
    get_sanitize_patterns,
    nocolors,
)

__all__ = ["nbval_options", "shares_run", "nbval_output", "compare"]

#: What nbval leaves out of a comparison (``IPyNbFile.__init__`` of nbval 0.11, without
#: ``--nbdime``: images are not compared).
SKIP_COMPARE = (
    "metadata",
    "traceback",
    "prompt_number",
    "output_type",
    "name",
    "execution_count",
    "application/vnd.jupyter.widget-view+json",
    "image/png",
    "image/jpeg",
)


def nbval_options(cell) -> dict:
    """A code cell's nbval options in ``--nbval-lax`` mode, as nbval's collector makes them:
    its tags, then its comment markers, ``check`` False unless one of them says so.

    Parameters
    ----------
    cell : nbformat.NotebookNode
        A code cell.

    Returns
    -------
    dict
        ``check``, ``skip``, ``check_exception`` (missing keys read False).
    """
    options = defaultdict(bool, find_metadata_tags(cell.metadata))
    options.update(dict(find_comment_markers(cell.source)))
    options.setdefault("check", False)
    return options


def shares_run(nb) -> bool:
    """Whether nbval would execute every code cell of ``nb`` as the chapter's run does: no
    cell skipped, none allowed to raise.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        The prepared (parameterised) notebook.

    Returns
    -------
    bool
    """
    opts = [nbval_options(c) for c in nb.cells if c.cell_type == "code"]
    return not any(o["skip"] or o["check_exception"] for o in opts)


def nbval_output(msg: dict) -> dict | None:
    """The output nbval keeps of one iopub message of a cell's execution (its ``runtest``):
    results, displays and streams, as sent (no display updates, no clearing).

    Parameters
    ----------
    msg : dict
        An iopub message whose parent is the cell's execute request.

    Returns
    -------
    dict or None
        The output (JSON-able), ``None`` for a message nbval ignores.
    """
    kind, content = msg["msg_type"], msg["content"]
    if kind in ("display_data", "execute_result"):
        out = {"output_type": kind, "metadata": content["metadata"], "data": content["data"]}
        if kind == "execute_result":
            out["execution_count"] = content["execution_count"]
        return out
    if kind == "stream":
        return {"output_type": "stream", "name": content["name"], "text": content["text"]}
    if kind == "error":
        return {k: content[k] for k in ("ename", "evalue", "traceback")} | {"output_type": "error"}
    return None


class _Comparison:
    """What nbval's ``IPyNbCell.compare_outputs`` needs of its cell: the parent's skips and
    sanitize patterns, the colours, the pytest hooks (its report on a difference)."""

    compare_outputs = IPyNbCell.compare_outputs
    format_output_compare = IPyNbCell.format_output_compare
    sanitize = IPyNbCell.sanitize
    colors = nocolors

    def __init__(self, patterns, config):
        self.parent = type("Parent", (), {"skip_compare": SKIP_COMPARE, "sanitize_patterns": patterns})
        self.config, self.ihook = config, config.hook


def compare(ref_cell, outputs: list[dict], check: bool, sanitize_text: str, config) -> str:
    """nbval's verdict on one code cell after it ran: "" when all is well.

    Parameters
    ----------
    ref_cell : nbformat.NotebookNode
        The cell as stored in the notebook (outputs and execution count).
    outputs : list of dict
        What the kernel sent when the chapter's run executed it (:func:`nbval_output`).
    check : bool
        Compare them (the cell's nbval options say ``check``, and it ran).
    sanitize_text : str
        The sanitize file's text (``notebooks/nbval-sanitize.cfg``).
    config : pytest.Config
        The running session's (its assertion rewriting formats a difference).

    Returns
    -------
    str
        "" or nbval's message: a stored output without an execution count, or what
        differs, the reference against this run.
    """
    unrun = ref_cell.execution_count is None  # a reference never run is not compared
    if unrun and ref_cell.outputs:
        return "Unrun reference cell has outputs"
    if not check or unrun:
        return ""
    test = coalesce_streams([NotebookNode(o) for o in outputs])
    ref = coalesce_streams([NotebookNode(dict(o)) for o in ref_cell.outputs])
    cmp = _Comparison(dict(get_sanitize_patterns(sanitize_text)), config)
    if cmp.compare_outputs(test, ref):
        return ""
    return re.sub(r"\x1b\[[0-9;]*m", "", "Cell outputs differ\n" + "\n".join(cmp.comparison_traceback))
