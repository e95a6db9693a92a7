"""What a failing grader prints: where the result differs, in words, and the case as code.

- :func:`where_differs` compares a result with the reference's and says where they part,
  counting as a reader does: "row 2, column 1 of the 2nd returned value (result[1][1, 0])
  is 5, expected 4";
- :func:`describe_inputs` writes a case's inputs as Python to paste, one ``name = value``
  per line: numbers and arrays of at most :data:`SHOWN_NUMBERS` numbers in full
  (``np.array([...])``, every digit a float holds); a larger array, or an object that has no
  literal (a network, a rig), as ``name = ...`` with what it is;
- :func:`rerun_call` writes the call that runs one case again, ``check_x(f, case=2)``: the
  student's own call of the checker (read from its source) with ``case=`` added, or the
  checker's name and parameters where the source cannot be read.
"""

from __future__ import annotations

import ast
import inspect
import linecache
import math
import sys
from collections.abc import Callable, Iterable

import numpy as np

__all__ = ["SHOWN_NUMBERS", "where_differs", "describe_inputs", "as_code", "rerun_call"]

#: An input with more numbers than this is not printed (its shape is); ``.inputs`` holds it.
SHOWN_NUMBERS = 60
#: A printed array longer than this many characters is broken into one line per row.
_WIDTH = 88


def _ordinal(k: int) -> str:
    suffix = "th" if k % 100 in (11, 12, 13) else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


def _number(x) -> str:
    """A Python literal of one number (``np.nan`` and ``np.inf`` where it is not finite)."""
    x = x.item() if isinstance(x, np.generic) else x
    if isinstance(x, float) and not math.isfinite(x):
        return "np.nan" if math.isnan(x) else ("np.inf" if x > 0 else "-np.inf")
    return repr(x)


def _nested(rows, indent: str) -> str:
    """Nested lists of literals, on one line if it is short, else one line per row."""
    if not isinstance(rows, list):
        return _number(rows)
    flat = "[" + ", ".join(_nested(r, "") for r in rows) + "]"
    if len(indent) + len(flat) <= _WIDTH or not rows:
        return flat
    inner = indent + "    "
    if isinstance(rows[0], list):
        return "[\n" + "".join(f"{inner}{_nested(r, inner)},\n" for r in rows) + f"{indent}]"
    lines, line = [], ""
    for item in (_number(r) for r in rows):
        if line and len(inner) + len(line) + len(item) + 2 > _WIDTH:
            lines.append(line)
            line = ""
        line += item + ", "
    return "[\n" + "".join(f"{inner}{s.rstrip()}\n" for s in [*lines, line]) + f"{indent}]"


def _array_code(a: np.ndarray) -> str:
    dtype = "" if np.array(a.tolist()).dtype == a.dtype else f", dtype=np.{a.dtype.name}"
    if a.size == 0:
        return f"np.zeros({a.shape}{dtype})"
    return f"np.array({_nested(a.tolist(), '')}{dtype})"


def _count(x) -> int | None:
    """How many numbers ``x`` holds, or None if it has no literal (an object, a function)."""
    if x is None or isinstance(x, (str, bytes, bool, int, float, complex, np.generic)):
        return 1
    if isinstance(x, np.ndarray):
        return x.size if x.dtype.kind in "biufc" else None
    if isinstance(x, (list, tuple)):
        counts = [_count(v) for v in x]
        return None if None in counts else sum(counts)
    return None


def _literal(x) -> str:
    if isinstance(x, np.ndarray):
        return _array_code(x)
    if isinstance(x, (list, tuple)):
        items = [_literal(v) for v in x]
        if isinstance(x, tuple):
            return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"
        return "[" + ", ".join(items) + "]"
    return _number(x)


def _what(x) -> str:
    if isinstance(x, np.ndarray):
        return f"an array of shape {x.shape}: {x.size} numbers"
    if isinstance(x, (list, tuple)) and _count(x) is not None:
        return f"a {type(x).__name__} of {len(x)} items, {_count(x)} numbers"
    if inspect.isfunction(x) or inspect.ismethod(x):
        kind = "method" if inspect.ismethod(x) else "function"
        return f"the {kind} {x.__module__}.{x.__qualname__}"
    return f"an object of type {type(x).__name__}"


def as_code(x) -> str:
    """One input as the right-hand side of an assignment.

    Parameters
    ----------
    x : object
        The input.

    Returns
    -------
    str
        A Python literal (``np.array([...])``, ``17``, ``(1.5, 2.0)``) if it has one and at
        most :data:`SHOWN_NUMBERS` numbers, else ``"...  # "`` and what it is (its shape).
    """
    n = _count(x)
    if n is not None and n <= SHOWN_NUMBERS:
        return _literal(x)
    return f"...  # {_what(x)}, not printed"


def _argument_names(fn: Callable | None, n: int) -> list[str] | None:
    """``fn``'s first ``n`` positional parameters, if it has that many, uniquely named."""
    try:
        params = list(inspect.signature(fn).parameters.values())
    except (TypeError, ValueError):
        return None
    names = [p.name for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)][:n]
    if len(names) < n or len(set(names)) < n or "np" in names:
        return None
    return names


def describe_inputs(args: tuple, names: Iterable[str] = ()) -> str:
    """The inputs of one case as Python to paste, one ``name = value`` per line.

    Parameters
    ----------
    args : tuple
        The case's arguments.
    names : iterable of str
        Their names (the student's parameters); ``arg1``, ``arg2``, ... where missing.

    Returns
    -------
    str
        One line per argument (a long array spans several), see :func:`as_code`.
    """
    names = list(names)
    names += [f"arg{k + 1}" for k in range(len(names), len(args))]
    return "\n".join(f"{name} = {as_code(a)}" for name, a in zip(names, args))


def function_name(fn: Callable) -> str:
    """``fn``'s name, or ``your_function`` where it has none (a lambda)."""
    name = getattr(fn, "__name__", "")
    return name if name.isidentifier() else "your_function"


def inputs_text(args: tuple, student: Callable, wrapper: Callable, rerun: str, name: str) -> str:
    """The failing case's inputs as code, then how to call the student's function on them.

    ``student`` is the function the student gave, ``name`` what to call it, ``wrapper`` the
    one the grader calls (a checker may wrap the student's); ``rerun`` the call that runs the
    case again ("" where there is none: then the grade's ``.inputs`` holds the inputs)."""
    names = _argument_names(student, len(args)) or _argument_names(wrapper, len(args))
    names = names or [f"arg{k + 1}" for k in range(len(args))]
    text = describe_inputs(args, names)
    if all(_count(a) is not None and _count(a) <= SHOWN_NUMBERS for a in args):
        return f"Its inputs, as code to paste:\n{text}\n{name}({', '.join(names)})"
    holder = f"{rerun}.inputs" if rerun else "the result's .inputs"
    return (
        f"Its inputs, as code (an input of more than {SHOWN_NUMBERS} numbers, or an object, is not printed; "
        f"{holder} holds them all):\n{text}\nTo call your function on them: {name}(*{holder})"
    )


def _shown(g: float, w: float, fewest: int = 6) -> tuple[str, str]:
    """Two numbers with just enough digits to tell them apart (``fewest`` to 17 significant)."""
    for digits in (fewest, *range(fewest + 2, 17, 2), 17):
        a, b = f"{g:.{digits}g}", f"{w:.{digits}g}"
        if a != b:
            return a, b
    return repr(g), repr(w)


def _place(index: tuple[int, ...]) -> str:
    if len(index) == 1:
        return f"entry {index[0] + 1} of "
    if len(index) == 2:
        return f"row {index[0] + 1}, column {index[1] + 1} of "
    return f"entry ({', '.join(str(i + 1) for i in index)}) counting from 1, of "


def _named(what: str, path: str) -> str:
    return what if path == "result" else f"{what} ({path})"


def _differs(got, want, rtol: float, atol: float, what: str, path: str) -> str | None:
    if isinstance(want, tuple):
        if not isinstance(got, tuple):
            return f"{what} is one {type(got).__name__}, expected a tuple of {len(want)} values"
        if len(got) != len(want):
            return f"{what} is a tuple of {len(got)}, expected a tuple of {len(want)} values"
        for k, (g, w) in enumerate(zip(got, want)):
            part = f"the {_ordinal(k + 1)} returned value" if path == "result" else f"item {k + 1} of {what}"
            why = _differs(g, w, rtol, atol, part, f"{path}[{k}]")
            if why is not None:
                return why
        return None
    try:
        g = np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        return f"{_named(what, path)} is a {type(got).__name__}, expected numbers"
    w = np.asarray(want, dtype=float)
    if g.shape != w.shape:
        said = {(): "a single number"}
        return (
            f"{_named(what, path)} is {said.get(g.shape, f'an array of shape {g.shape}')}, "
            f"expected {said.get(w.shape, f'an array of shape {w.shape}')}"
        )
    tol = atol + rtol * np.abs(w)
    with np.errstate(invalid="ignore"):
        wrong = ~np.isfinite(g) | (np.abs(g - w) > tol)
    if not wrong.any():
        return None
    index = tuple(int(i) for i in np.argwhere(wrong)[0])
    gi, wi, ti = float(g[index]), float(w[index]), float(tol[index])
    a, b = _shown(gi, wi)
    where = f"{_place(index)}{what} ({path}[{', '.join(map(str, index))}])" if index else _named(what, path)
    text = f"{where} is {a}, expected {b}"
    if math.isfinite(gi) and math.isfinite(wi):
        text += " (off by {}, allowed {})".format(*_shown(abs(gi - wi), ti, 2))
    if wrong.sum() > 1:
        text += f"; {int(wrong.sum()) - 1} more of its {wrong.size} entries differ"
    return text


def where_differs(got, want, rtol: float, atol: float) -> str | None:
    """Where a result differs from the reference's, in words.

    Parameters
    ----------
    got, want : object
        The student's result and the reference's: a number, an array, or a tuple of them.
    rtol, atol : float
        Tolerance of every compared number: ``|got - want| <= atol + rtol |want|``; a number
        that is not finite never matches.

    Returns
    -------
    str or None
        None if they match; else the first entry (in reading order) that does not, counted
        from 1 ("row 2, column 1 of the 2nd returned value (result[1][1, 0]) is 5, expected
        4 (off by 1, allowed 4e-07)"), or the shape or type that differs.
    """
    return _differs(got, want, rtol, atol, "the result", "result")


def _call_site(checker: Callable) -> ast.Call | None:
    """The expression that called ``checker`` (found on the stack), if its source is readable."""
    frame = sys._getframe(1)
    while frame is not None and frame.f_code is not checker.__code__:
        frame = frame.f_back
    caller = frame.f_back if frame is not None else None
    if caller is None:
        return None
    line, end, col, end_col = list(caller.f_code.co_positions())[caller.f_lasti // 2]
    lines = linecache.getlines(caller.f_code.co_filename, caller.f_globals)
    if None in (line, end, col, end_col) or not lines or end > len(lines):
        return None
    code = [s.encode() for s in lines[line - 1 : end]]  # the columns count UTF-8 bytes
    text = b"".join(code)[col : sum(map(len, code)) - len(code[-1]) + end_col].decode()
    call = ast.parse(text.strip(), mode="eval").body
    func = getattr(call, "func", None)
    name = func.id if isinstance(func, ast.Name) else getattr(func, "attr", None)
    return call if isinstance(call, ast.Call) and name == checker.__name__ else None


def rerun_call(checker: Callable, student: Callable, case: int) -> tuple[str, str]:
    """The call that runs case ``case`` of ``checker`` again.

    Parameters
    ----------
    checker : callable
        The ``check_*`` function, on the stack (this is called while it runs).
    student : callable
        The student's function, as given to ``checker``.
    case : int
        The case, counted from 1.

    Returns
    -------
    call : str
        The student's own call with ``case=`` set and no ``show=`` (``check_gd_step(gd_step,
        model, robot.u_max_rad, case=4)``), or, where its source cannot be read, the checker's
        name with the student's function's and its other parameters' names.
    name : str
        The student's function's name: as the call spells it, else its ``__name__``, else
        ``your_function`` (a lambda).
    """
    name = function_name(student)
    try:
        call = _call_site(checker)
    except (SyntaxError, ValueError, IndexError, UnicodeDecodeError):  # not one expression, or no positions
        call = None
    if call is not None:
        kept = [k for k in call.keywords if k.arg not in ("case", "show")]  # a rerun is shown
        call.keywords = kept + [ast.keyword("case", ast.Constant(case))]
        first = call.args[0] if call.args else None
        return ast.unparse(call), first.id if isinstance(first, ast.Name) else name
    params = list(inspect.signature(checker).parameters.values())
    names = [name] + [p.name for p in params[1:] if p.kind is p.POSITIONAL_OR_KEYWORD and p.default is p.empty]
    return f"{checker.__name__}({', '.join(names)}, case={case})", name
