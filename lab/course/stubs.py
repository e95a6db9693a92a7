"""A solution cell's stub: the functions the student writes, their bodies left to write.

:func:`stub_source` keeps each top-level function's decorators, signature and docstring
and replaces its body by ``raise NotImplementedError`` (the graders then say "not
implemented yet"); everything else in the cell is dropped. The student edition
(:mod:`lab.course.edition`) applies it to every cell tagged ``solution``.
"""

from __future__ import annotations

import ast

from lab.errors import InputError

__all__ = ["stub_source"]


def stub_source(source: str) -> str:
    """The student's version of a solution cell.

    Parameters
    ----------
    source : str
        The solution cell's Python source.

    Returns
    -------
    str
        Each top-level function with its signature and docstring, its body
        ``raise NotImplementedError``; everything else dropped (IPython's ``%`` magics and
        ``!`` shell lines too).

    Raises
    ------
    InputError
        When the cell is not Python (a syntax error), saying where.
    """
    # IPython's own lines (%matplotlib inline, %%time, !pip) are not Python: blank them,
    # keeping the line numbers, and parse the rest.
    lines = ["" if line.startswith(("%", "!")) else line for line in source.splitlines()]
    try:
        tree = ast.parse("\n".join(lines))
    except (SyntaxError, ValueError) as e:  # ValueError: a NUL character
        where = f"line {e.lineno}: " if getattr(e, "lineno", None) else ""
        raise InputError(f"a solution cell is not Python ({where}{getattr(e, 'msg', e)})") from None
    out = []
    for node in tree.body:
        if not isinstance(node, ast.FunctionDef):
            continue
        start = min([node.lineno, *(d.lineno for d in node.decorator_list)])
        head = "\n".join(lines[start - 1 : node.body[0].lineno - 1])  # decorators and signature
        doc = ast.get_docstring(node)
        doc = "\n".join(("    " + line) if line else "" for line in doc.split("\n")).lstrip() if doc else doc
        body = ([f'    """{doc}"""'] if doc else []) + [f'    raise NotImplementedError("exercise: write {node.name}")']
        out.append(head + "\n" + "\n".join(body))
    return "\n\n\n".join(out) + "\n"
