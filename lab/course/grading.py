"""Graders: a student's function checked against ``lab``'s own implementation.

:func:`grade` calls the student's function and the reference on every case (random
inputs the chapter's checker module draws), compares the results to a tolerance and
shows one result, once: green "passed", red "FAILED" or "not implemented yet". A failure
says where the result differs in words ("row 2, column 1 of the 2nd returned value is 5,
expected 4"), the call that runs that case alone (``check_x(f, case=2)``: every checker
passes its ``case=`` on) and the case's inputs as Python to paste (:mod:`lab.course.failures`).
In JupyterLab the result is HTML; elsewhere (papermill's text, a terminal) it is plain
text. A grader never raises (but for a ``case=`` that names no case), so the rest of the
chapter runs either way.

The references and the cases live in ``lab.course`` (one checker module per chapter), not
in a visible notebook cell: a grader cell calls its checker, it never spells the answer.
A checker builds all its cases every time, from its own seed, so case k of a rerun is case
k of the full check.
"""

from __future__ import annotations

import html
import operator
from collections.abc import Callable, Iterable

import numpy as np

from lab.course.failures import describe_inputs, function_name, inputs_text, rerun_call, where_differs
from lab.errors import InputError

__all__ = ["grade", "Grade", "NOT_IMPLEMENTED", "describe_inputs"]

NOT_IMPLEMENTED = "not implemented yet"
_COLOURS = {"passed": "#1a7f37", "failed": "#cf222e", "todo": "#9a6700"}


class Grade(str):
    """One grader's result: the plain line (the ``str`` itself) plus its status and details.

    Parameters
    ----------
    line : str
        The plain-text result.
    status : str
        "passed", "failed" or "todo".
    details : str
        How to rerun the failing case and its inputs, or "".
    case : int or None
        The failing case, counted from 1 (None unless it failed).
    inputs : tuple or None
        The failing case's arguments, all of them: ``f(*result.inputs)`` calls the
        student's function ``f`` on that case (None unless it failed).
    """

    status: str
    details: str
    case: int | None
    inputs: tuple | None
    _shown: bool

    def __new__(cls, line: str, status: str, details: str = "", *, case: int | None = None, inputs=None):
        self = super().__new__(cls, line)
        self.status, self.details, self._shown = status, details, False
        self.case, self.inputs = case, inputs
        return self

    def _repr_html_(self) -> str:
        colour = _COLOURS[self.status]
        mark = {"passed": "&#10004;", "failed": "&#10008;", "todo": "&#8230;"}[self.status]
        body = f'<b style="color:{colour}">{mark} {html.escape(str(self))}</b>'
        if self.details:
            body += f'<pre style="margin:0.3em 0 0 1.5em">{html.escape(self.details)}</pre>'
        style = f"border-left:4px solid {colour};padding-left:0.5em"
        return f'<div class="lab-grade lab-grade-{self.status}" style="{style}">{body}</div>'

    def show(self) -> None:
        """Show the result once: HTML (with the plain text as fallback) in an IPython
        kernel, a printed line elsewhere."""
        self._shown = True
        plain = str(self) + (f"\n{self.details}" if self.details else "")
        try:
            from IPython import get_ipython
            from IPython.display import display
        except ImportError:  # pragma: no cover - IPython is a dependency of the course
            get_ipython = None
        if get_ipython is not None and get_ipython() is not None:
            display({"text/plain": plain, "text/html": self._repr_html_()}, raw=True)
        else:
            print(plain)

    def _ipython_display_(self) -> None:
        # The grader cell's last expression: already shown by grade(), so nothing more.
        if not self._shown:
            self.show()


def _chosen(case, n: int, checker: Callable | None) -> list[int]:
    """The cases to run, counted from 0: all, or the one ``case`` (counted from 1) names."""
    if case is None:
        return list(range(n))
    who = f"{checker.__name__} has" if checker is not None else "there are"
    try:
        k = operator.index(case) if not isinstance(case, bool) else None
    except TypeError:
        k = None
    if k is None or not 1 <= k <= n:
        raise InputError(f"case must be a whole number from 1 to {n} ({who} {n} cases), got {case!r}")
    return [k - 1]


def grade(
    name: str,
    student: Callable,
    reference: Callable,
    cases: Iterable[tuple],
    *,
    rtol: float = 1e-7,
    atol: float = 1e-10,
    hint: str = "",
    show: bool = True,
    case: int | None = None,
    checker: Callable | None = None,
    given: Callable | None = None,
) -> Grade:
    """Check ``student(*args)`` against ``reference(*args)`` for every ``args`` in ``cases``.

    Parameters
    ----------
    name : str
        The exercise's title, as the chapter gives it.
    student, reference : callable
        The two functions, called with the same arguments.
    cases : iterable of tuple
        Tuples of arguments.
    rtol, atol : float
        Tolerance of every compared number: ``|got - want| <= atol + rtol |want|``.
    hint : str
        Shown after a wrong result (not after an exception): the idea, never the answer.
    show : bool
        Show the result (once); off for a caller that collects results.
    case : int, optional
        Run only this case, counted from 1 (what a failure's rerun line passes).
    checker : callable, optional
        The ``check_*`` function that calls this (and is running): a failure names the call
        that reruns the case, ``checker(..., case=k)``.
    given : callable, optional
        The student's function as given to ``checker``, where ``student`` wraps it: it names
        the inputs and the call in a failure. Default: ``student``.

    Returns
    -------
    Grade
        "passed", "FAILED ..." (which case, where it differs, how to rerun it and its
        inputs as code) or "not implemented yet". Never raises but for a bad ``case``.

    Raises
    ------
    InputError
        ``case`` is not a whole number from 1 to the number of cases.
    """
    cases = list(cases)
    given = student if given is None else given
    result = None
    for k in _chosen(case, len(cases), checker):
        args, why = cases[k], None
        kept = tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)  # as given, if changed
        try:
            got = student(*args)
        except NotImplementedError:
            line = f"exercise '{name}': {NOT_IMPLEMENTED} - write the function above, then run this cell again"
            result = Grade(line, "todo")
            break
        except Exception as err:  # noqa: BLE001 - a student's bug is reported, not raised
            why = f"{type(err).__name__}: {err}"
        else:
            why = where_differs(got, reference(*args), rtol, atol)
            why = None if why is None else why + (f". Hint: {hint}" if hint else "")
        if why is not None:
            line = f"exercise '{name}': FAILED on case {k + 1} of {len(cases)}: {why}"
            rerun, called = rerun_call(checker, given, k + 1) if checker is not None else ("", "")
            called = called or function_name(given)
            details = (f"To rerun it: {rerun}\n" if rerun else "") + inputs_text(kept, given, student, rerun, called)
            result = Grade(line, "failed", details, case=k + 1, inputs=kept)
            break
    if result is None and case is not None:
        result = Grade(f"exercise '{name}': case {k + 1} of {len(cases)} passed", "passed")
    elif result is None:
        result = Grade(f"exercise '{name}': passed ({len(cases)} random cases)", "passed")
    if show:
        result.show()
    return result
