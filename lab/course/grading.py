"""Graders: a student's function checked against ``lab``'s own implementation.

:func:`grade` calls the student's function and the reference on every case (random
inputs the chapter's checker module draws), compares the results to a tolerance and
shows one result, once: green "passed", red "FAILED" with what differs and the failing
case's inputs (shapes and a few values), or "not implemented yet". In JupyterLab the
result is HTML; elsewhere (papermill's text, a terminal) it is one plain line. A grader
never raises, so the rest of the chapter runs either way.

The references and the cases live in ``lab.course`` (one checker module per chapter), not
in a visible notebook cell: a grader cell calls its checker, it never spells the answer.
"""

from __future__ import annotations

import html
from collections.abc import Callable, Iterable

import numpy as np

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
        The failing case's inputs, or "".
    """

    status: str
    details: str
    _shown: bool

    def __new__(cls, line: str, status: str, details: str = ""):
        self = super().__new__(cls, line)
        self.status, self.details, self._shown = status, details, False
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


def _value(x) -> str:
    if isinstance(x, (str, bytes, bool, int, float, np.generic)) or x is None:
        return repr(x.item() if isinstance(x, np.generic) else x)
    if isinstance(x, (tuple, list)) and len(x) <= 4 and all(np.isscalar(v) for v in x):
        return repr(type(x)(v.item() if isinstance(v, np.generic) else v for v in x))
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        return f"a {type(x).__name__}"
    flat = a.ravel()
    few = ", ".join(f"{v:.4g}" for v in flat[:4]) + (", …" if flat.size > 4 else "")
    return f"array {a.shape} [{few}]"


def describe_inputs(args: tuple, names: Iterable[str] = ()) -> str:
    """The inputs of one case, one per line: name (or position), then the value, or the
    shape and first values of an array."""
    names = list(names)
    return "\n".join(f"{names[k] if k < len(names) else f'argument {k + 1}'}: {_value(a)}" for k, a in enumerate(args))


def _compare(got, want, rtol: float, atol: float) -> str | None:
    """None if ``got`` matches ``want`` (arrays, numbers or tuples of them), else what differs."""
    if isinstance(want, tuple):
        if not isinstance(got, tuple) or len(got) != len(want):
            return f"expected a tuple of {len(want)} values, got {type(got).__name__}"
        for k, (g, w) in enumerate(zip(got, want)):
            if (why := _compare(g, w, rtol, atol)) is not None:
                return f"item {k}: {why}"
        return None
    try:
        g = np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        return f"expected numbers, got {type(got).__name__}"
    w = np.asarray(want, dtype=float)
    if g.shape != w.shape:
        return f"shape {g.shape}, expected {w.shape}"
    err = np.abs(g - w)
    tol = atol + rtol * np.abs(w)
    if not np.all(np.isfinite(g)) or np.any(err > tol):
        excess = np.where(np.isfinite(err), err - tol, np.inf)
        i = np.unravel_index(int(np.argmax(excess)), err.shape) if err.ndim else ()
        return f"at index {tuple(int(k) for k in i)}: {g[i]:.6g} instead of {w[i]:.6g}"
    return None


def _arg_names(fn: Callable) -> list[str]:
    import inspect

    try:
        return list(inspect.signature(fn).parameters)
    except (TypeError, ValueError):
        return []


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

    Returns
    -------
    Grade
        "passed", "FAILED ..." (which case, what differs, its inputs) or
        "not implemented yet". Never raises.
    """
    cases = list(cases)
    names = _arg_names(student)
    result = None
    for k, args in enumerate(cases):
        try:
            got = student(*args)
        except NotImplementedError:
            line = f"exercise '{name}': {NOT_IMPLEMENTED} - write the function above, then run this cell again"
            result = Grade(line, "todo")
            break
        except Exception as err:  # noqa: BLE001 - a student's bug is reported, not raised
            line = f"exercise '{name}': FAILED on case {k + 1} of {len(cases)}: {type(err).__name__}: {err}"
            result = Grade(line, "failed", "inputs of that case:\n" + describe_inputs(args, names))
            break
        why = _compare(got, reference(*args), rtol, atol)
        if why is not None:
            line = f"exercise '{name}': FAILED on case {k + 1} of {len(cases)}: {why}"
            line += f". Hint: {hint}" if hint else ""
            result = Grade(line, "failed", "inputs of that case:\n" + describe_inputs(args, names))
            break
    if result is None:
        result = Grade(f"exercise '{name}': passed ({len(cases)} random cases)", "passed")
    if show:
        result.show()
    return result
