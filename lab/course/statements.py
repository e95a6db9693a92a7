"""Computed statements: a chapter's sentences about its own results, formatted from the run.

A sentence that states a measured number or a comparison ("the early-stopped model tracks
at 0.45 cm, above the paper's 0.04-0.06 cm") must hold in quick mode as in full mode.
Such a sentence is not typed into a Markdown cell: a code cell builds it from the run's
values with :func:`say`, and :func:`than` picks the comparison's word from the numbers, so
it cannot contradict them. ``tests/test_quick_statements.py`` checks that the chapters'
Markdown states no other run-dependent number and that every statement renders.
"""

from __future__ import annotations

__all__ = ["say", "than", "Statement", "STATEMENT_KEY"]

#: Output metadata key that marks a computed statement (found by the tests).
STATEMENT_KEY = "lab_statement"


def than(value: float, reference: float, lower: str = "below", higher: str = "above", same: str | None = None) -> str:
    """The word comparing ``value`` with ``reference``.

    Parameters
    ----------
    value, reference : float
        The two numbers, in the same unit.
    lower, higher : str
        The word when ``value`` is below, or not below, ``reference``.
    same : str, optional
        The word when they are equal to 3 significant digits; default: no such word.

    Returns
    -------
    str
        ``lower``, ``higher`` or ``same``.
    """
    if same is not None and f"{value:.3g}" == f"{reference:.3g}":
        return same
    return lower if value < reference else higher


class Statement(str):
    """A computed statement: the text (the ``str`` itself), already shown by :func:`say`;
    IPython does not show it a second time as the cell's result."""

    def _ipython_display_(self) -> None:
        pass


def say(text: str) -> Statement:
    """Show ``text`` as the cell's output, once, marked as a computed statement.

    Parameters
    ----------
    text : str
        Markdown, already formatted from the run's values; printed outside IPython.

    Returns
    -------
    Statement
        ``text``, which IPython does not show a second time.
    """
    try:
        from IPython import get_ipython
        from IPython.display import display
    except ImportError:  # pragma: no cover
        get_ipython = None
    if get_ipython is not None and get_ipython() is not None:
        display({"text/markdown": text, "text/plain": text}, raw=True, metadata={STATEMENT_KEY: True})
    else:
        print(text)
    return Statement(text)
