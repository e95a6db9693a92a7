"""Which cells of a chapter's student edition can behave differently from the chapter itself.

The student edition (:mod:`lab.course.edition`) changes two kinds of cells: each solution
cell becomes a stub (same functions, bodies ``raise NotImplementedError``), and the
parameters cell's relative paths move one folder up (the edition lives in
``build/student/``). ``tests/test_exercises.py`` shows that the edition runs and that its
graders say "not implemented yet". Executing the edition in full would repeat all that the
chapter's own run (``tests/chapter_run.py``) has just done; :func:`replay_plan` lists the
cells that can behave differently instead: the stubs, every grader, and every cell that
reads a name one of those changed, transitively. They run once more, in the chapter's
kernel, after its last cell. Every other cell is the same code reading the same values at
its position, so the chapter's run already showed that it runs.

A plan is made only when that argument holds; otherwise :func:`replay_plan` says why and
the edition is executed in full, as before. It holds when

- the edition's cells match the chapter's one to one, identical but for the parameters
  cell and the solution cells; no cell uses IPython syntax (``%``, ``!``) or reaches names
  by string (``globals``, ``eval``, ...);
- each solution cell holds only function definitions (the stub defines the same names);
- the edition's parameters cell, run from ``build/student/``, names the same values and
  files (a path: a value that differs, or a file found from ``notebooks/``) as the
  chapter's from ``notebooks/``, and no other cell holds a path relative to
  the working folder (``"./"``, ``"../"``; the chapter's run also records every file it
  opens by a relative path, see ``chapter_run``);
- each replayed cell, run after the chapter's end, finds each name it reads as it was at
  its position: the replay binds the name anew before it (and replays every cell that
  writes it since), or no cell from it onward writes the name and no replayed cell before
  it does. Where neither holds, the cell that last bound the name for certain before it
  (not the parameters cell, which the edition changes) and every cell that changed it
  since are replayed too ("rebind"), and so on for what those read.

Names are followed statically (:mod:`symtable`, :mod:`ast`): a cell reads the global names
it and its functions reference (but those it binds before each use: in a loop's body, as a
loop's variable, in every branch of a ``try`` that goes on), and writes the names it binds
and, conservatively, every object it may change (an attribute or item assigned, a method
called, an argument passed, but to a builtin such as ``print`` or ``len``, or a name only
ever bound to a string, a number or a tuple of them, which nothing can change).
A grader is trusted to report only: :func:`lab.course.grade` calls the student's function
first, so with a stub it stops at that call, and the cases it builds before it are the ones
the chapter's run built at the same position.
"""

from __future__ import annotations

import ast
import json
import os
import symtable
from pathlib import Path
from typing import NamedTuple

__all__ = ["ReplayCell", "Plan", "replay_plan"]

PARAMETERS, SOLUTION, GRADER = "parameters", "solution", "grader"
#: names that reach variables by string, which the static analysis cannot follow, and the
#: functions that read or change the working folder
DYNAMIC = {"globals", "locals", "vars", "eval", "exec", "get_ipython", "__import__", "getcwd", "chdir", "cwd"}


#: builtins that change none of their arguments (unless a cell rebinds one: then no plan)
PURE = {"print", "len", "repr", "str", "int", "float", "bool", "abs", "round", "min", "max", "sum", "sorted"}
PURE |= {"isinstance", "enumerate", "zip", "range", "format", "any", "all", "list", "tuple", "set", "dict", "type"}


class ReplayCell(NamedTuple):
    """One cell to run again: its ``index`` in the notebook, its ``source`` in the student
    edition and its ``kind`` ("stub", "grader", "dependent" or "rebind")."""

    index: int
    source: str
    kind: str


class Plan(NamedTuple):
    """The cells to replay, in order, or ``None`` with the ``reason`` the edition must be
    executed in full."""

    cells: list[ReplayCell] | None
    reason: str


def cell_source(cell: dict) -> str:
    """A cell's source as one string."""
    src = cell.get("source", "")
    return src if isinstance(src, str) else "".join(src)


def _tags(cell: dict) -> list[str]:
    return cell.get("metadata", {}).get("tags", [])


def _base(node) -> str | None:
    """The variable at the root of ``a.b[c].d``, if any (not of a call's result)."""
    while isinstance(node, (ast.Attribute, ast.Subscript, ast.Starred)):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


def _immutable(node) -> bool:
    """Whether the expression ``node`` gives an immutable value whatever the names hold: a
    literal number, string or None, an f-string, a tuple of such, or a choice between them."""
    if isinstance(node, (ast.Constant, ast.JoinedStr)):
        return True
    if isinstance(node, ast.Tuple):
        return all(_immutable(e) for e in node.elts)
    if isinstance(node, ast.IfExp):
        return _immutable(node.body) and _immutable(node.orelse)
    if isinstance(node, ast.UnaryOp):
        return isinstance(node.operand, ast.Constant)
    return False


def _stored_before_loads(tree) -> set[str]:
    """Names every load of which comes after an assignment to it earlier in the same block
    (``n = f(); g(n)``, at the cell's top level or in a loop's body) or inside a loop over it
    (``for n in ...: g(n)``): the cell reads only its own values, whatever the name held before."""
    loads, covered = {}, {}
    for n in ast.walk(tree):
        if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load):
            loads.setdefault(n.id, set()).add(id(n))
    for node in ast.walk(tree):
        if isinstance(node, (ast.For, ast.AsyncFor)):
            inside = {id(m) for stmt in node.body for m in ast.walk(stmt)}
            for x in _target_names(node.target):
                covered.setdefault(x, set()).update(inside)
        for block in (getattr(node, f, None) for f in ("body", "orelse", "finalbody")):
            if not isinstance(block, list):
                continue
            for i, stmt in enumerate(block):
                names = _surely_bound([stmt])
                if names:
                    after = {id(m) for later in block[i + 1 :] for m in ast.walk(later)}
                    for x in names:
                        covered.setdefault(x, set()).update(after)
    return {x for x, ids in covered.items() if loads.get(x, set()) <= ids}


def _surely_bound(block: list) -> set[str]:
    """Names that the statements ``block`` bind on every path through them that goes on
    after them (a ``try``: its body and each handler that does not raise; an ``if``: both
    branches)."""
    out = set()
    for stmt in block:
        if isinstance(stmt, ast.Assign):
            out.update(x for t in stmt.targets for x in _target_names(t))
        elif isinstance(stmt, ast.AnnAssign) and stmt.value is not None:
            out.update(_target_names(stmt.target))
        elif isinstance(stmt, (ast.Import, ast.ImportFrom)):
            out.update(_import_names(stmt))
        elif isinstance(stmt, (ast.FunctionDef, ast.ClassDef)):
            out.add(stmt.name)
        elif isinstance(stmt, ast.If):
            out |= _surely_bound(stmt.body) & _surely_bound(stmt.orelse)
        elif isinstance(stmt, ast.With):
            out |= _surely_bound(stmt.body)
        elif isinstance(stmt, ast.Try):
            paths = [_surely_bound(stmt.body + stmt.orelse)]
            paths += [_surely_bound(h.body) for h in stmt.handlers if not isinstance(h.body[-1], ast.Raise)]
            out |= set.intersection(*paths) | _surely_bound(stmt.finalbody)
    return out


def _target_names(t) -> list[str]:
    if isinstance(t, ast.Name):
        return [t.id]
    if isinstance(t, ast.Starred):
        return _target_names(t.value)
    if isinstance(t, (ast.Tuple, ast.List)):
        return [x for e in t.elts for x in _target_names(e)]
    return []


def _import_names(node) -> dict[str, tuple]:
    """The names an import statement binds, each with what it binds it to."""
    if isinstance(node, ast.Import):
        return {
            (a.asname or a.name.split(".")[0]): ("import", a.name if a.asname else a.name.split(".")[0])
            for a in node.names
        }
    return {(a.asname or a.name): ("from", node.module, node.level, a.name) for a in node.names}


class _Cell:
    """What one cell reads and writes (see the module's docstring)."""

    def __init__(self, src: str):
        tree, table = ast.parse(src), symtable.symtable(src, "<cell>", "exec")
        self.reads = {s.get_name() for s in table.get_symbols() if s.is_referenced()}
        self.binds = {s.get_name() for s in table.get_symbols() if s.is_assigned() or s.is_imported()}
        stack = list(table.get_children())
        while stack:  # functions, classes and comprehensions: the module names they use
            t = stack.pop()
            stack += t.get_children()
            for s in t.get_symbols():
                if s.is_global() and s.is_referenced():
                    self.reads.add(s.get_name())
                if s.is_declared_global() and s.is_assigned():
                    self.binds.add(s.get_name())
        self.imports = {
            k: v
            for n in ast.walk(tree)
            if isinstance(n, (ast.Import, ast.ImportFrom))
            for k, v in _import_names(n).items()
        }
        self.must, self.top_imports = {}, set()  # names bound unconditionally -> line where bound
        for n in tree.body:
            names = []
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names = [n.name]
            elif isinstance(n, (ast.Import, ast.ImportFrom)):
                names = list(_import_names(n))
                self.top_imports.update(names)
            elif isinstance(n, ast.Assign):
                names = [x for t in n.targets for x in _target_names(t)]
            elif isinstance(n, ast.AnnAssign) and n.value is not None:
                names = _target_names(n.target)
            for x in names:
                self.must.setdefault(x, n.end_lineno)
        self.reads -= _stored_before_loads(tree)
        self.mutates = set()
        for n in ast.walk(tree):
            targets = []
            if isinstance(n, (ast.Assign, ast.Delete)):
                targets = n.targets
            elif isinstance(n, (ast.AugAssign, ast.AnnAssign, ast.For, ast.AsyncFor)):
                targets = [n.target]
            elif isinstance(n, ast.withitem) and n.optional_vars is not None:
                targets = [n.optional_vars]
            for e in (e for t in targets for e in ast.walk(t)):
                if isinstance(e, (ast.Attribute, ast.Subscript)) and isinstance(e.ctx, (ast.Store, ast.Del)):
                    self.mutates.add(_base(e))
            if isinstance(n, ast.Call):
                receivers = [n.func.value] if isinstance(n.func, ast.Attribute) else []
                if isinstance(n.func, ast.Name) and n.func.id in PURE:
                    continue
                self.mutates.update(_base(a) for a in [*receivers, *n.args, *(k.value for k in n.keywords)])
        self.mutates.discard(None)
        how_bound = {}  # name -> {whether each assignment in this cell gives an immutable value}
        for n in ast.walk(tree):
            pairs = []
            if isinstance(n, ast.Assign):
                pairs = [(t, n.value) for t in n.targets]
            elif isinstance(n, ast.AnnAssign) and n.value is not None:
                pairs = [(n.target, n.value)]
            for t, value in pairs:
                for x in _target_names(t):
                    how_bound.setdefault(x, set()).add(isinstance(t, ast.Name) and _immutable(value))
        self.immutable = {x for x in self.binds if how_bound.get(x) == {True}}
        attributes = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
        self.dynamic = sorted((self.reads | attributes) & DYNAMIC)
        fragments = {id(v) for n in ast.walk(tree) if isinstance(n, ast.JoinedStr) for v in n.values}  # f"{a}..{b}"
        self.relative = sorted(
            n.value
            for n in ast.walk(tree)
            if isinstance(n, ast.Constant)
            and isinstance(n.value, str)
            and (n.value.startswith(("./", "../")) or (n.value == ".." and id(n) not in fragments))
        )


def _same_parameters(source: str, student: str, notebooks: Path, student_dir: Path) -> str:
    """ "" when the two parameters cells name the same values (paths: the same files from
    their folders), else what differs."""
    ours, theirs = {}, {}
    try:
        exec(source, ours)  # noqa: S102 - the chapters' own parameters cells (assignments)
        exec(student, theirs)  # noqa: S102
    except Exception as e:  # noqa: BLE001
        return f"its parameters cell does not run on its own ({type(e).__name__}: {e})"
    for name in (set(ours) | set(theirs)) - {"__builtins__"}:
        a, b = ours.get(name), theirs.get(name)
        if a == b and not (isinstance(a, str) and a and (notebooks / a).exists()):
            continue  # the same value, not a file found from notebooks/
        if not (isinstance(a, str) and isinstance(b, str)):
            return f"parameter {name} differs in the edition ({a!r}, {b!r})"
        if os.path.normpath(notebooks / a) != os.path.normpath(student_dir / b):
            return (
                f"parameter {name} names another file in the edition ({a!r} from notebooks/, {b!r} from build/student/)"
            )
    return ""


def replay_plan(source: Path, edition: str, student_dir: Path) -> Plan:
    """The cells of the student edition to run after the chapter's run (see the module's
    docstring), or why the edition must be executed in full.

    Parameters
    ----------
    source : pathlib.Path
        The chapter, ``notebooks/NN_name.ipynb``.
    edition : str
        Its student edition's ``.ipynb`` text (``lab.course.edition.edition_text``).
    student_dir : pathlib.Path
        The folder the edition is written to and run from (``build/student``).

    Returns
    -------
    Plan
        The stubs, graders and dependent cells in notebook order, or ``None`` and a reason.
    """
    ours, theirs = json.loads(source.read_text())["cells"], json.loads(edition)["cells"]
    if [c["cell_type"] for c in ours] != [c["cell_type"] for c in theirs]:
        return Plan(None, "the edition's cells do not match the chapter's one to one")
    code = [i for i, c in enumerate(ours) if c["cell_type"] == "code"]
    cells, tags = {}, {i: _tags(ours[i]) for i in code}
    for i in code:
        src, student = cell_source(ours[i]), cell_source(theirs[i])
        if any(line.lstrip().startswith(("%", "!")) for line in src.splitlines()):
            return Plan(None, f"cell {i} uses IPython syntax")
        try:
            cells[i] = _Cell(src)
        except SyntaxError as e:
            return Plan(None, f"cell {i} is not Python ({e.msg})")
        if cells[i].dynamic:
            return Plan(None, f"cell {i} uses {cells[i].dynamic[0]}: names or a folder the analysis cannot follow")
        if PARAMETERS in tags[i]:
            why = _same_parameters(src, student, source.resolve().parent, student_dir.resolve())
            if why:
                return Plan(None, why)
        elif SOLUTION in tags[i]:
            tree = ast.parse(src)
            if not all(isinstance(n, ast.FunctionDef) for n in tree.body):
                return Plan(None, f"solution cell {i} holds more than function definitions")
            if _Cell(student).must.keys() != cells[i].must.keys():
                return Plan(None, f"the stub of cell {i} defines other names than its solution")
        elif src != student:
            return Plan(None, f"cell {i} differs in the edition but is neither a parameters nor a solution cell")
        elif cells[i].relative:
            return Plan(None, f"cell {i} holds a path relative to the working folder: {cells[i].relative[0]!r}")

    # a name bound only ever by one and the same import, or never (a builtin), never changes
    how = {}
    for i in code:
        for x in cells[i].binds:
            how.setdefault(x, set()).add(cells[i].imports.get(x, ("bound by", i)))
    stable = {x for x, ways in how.items() if len(ways) == 1 and next(iter(ways))[0] != "bound by"}
    if how.keys() & PURE:
        return Plan(None, f"a cell rebinds the builtin {sorted(how.keys() & PURE)[0]}")
    # a name only ever bound to an immutable value cannot be changed, only bound anew
    immutable = {x for x in how if all(x in cells[i].immutable for i in code if x in cells[i].binds)}
    writes = {i: (cells[i].binds | (cells[i].mutates & how.keys() - immutable)) - stable for i in code}
    for i in code:
        if GRADER in tags[i]:  # a grader reports; it changes nothing it is given
            writes[i] = cells[i].binds - stable

    changed, replay, changed_at = set(), [], {}
    for i in code:
        c, changed_at[i] = cells[i], set(changed)
        if SOLUTION in tags[i]:
            replay.append(ReplayCell(i, cell_source(theirs[i]), "stub"))
            changed |= c.must.keys()
        elif GRADER in tags[i]:
            replay.append(ReplayCell(i, cell_source(theirs[i]), "grader"))
            changed |= c.binds - c.top_imports - stable
        elif c.reads & changed:
            replay.append(ReplayCell(i, cell_source(theirs[i]), "dependent"))
            changed |= writes[i] - c.top_imports
        else:
            changed -= c.must.keys()  # the same value in both editions from here on

    while True:  # until every replayed cell finds what it reads as it was at its position
        problem = _first_stale_read(replay, cells, code, writes, changed_at)
        if problem is None:
            break
        r, x, where = problem
        before = [k for k in code if k < r.index and x in writes[k]]
        fresh = [k for k in before if x in cells[k].must]
        again = {c.index for c in replay}
        rebind = [k for k in before if fresh and k >= fresh[-1] and k not in again]
        if not rebind or PARAMETERS in tags[fresh[-1]]:
            return Plan(None, f"cell {r.index} reads {x}, which the chapter changes elsewhere (cell {where})")
        # replay the cell that binds x before it, and every cell that changes x since
        replay = sorted(replay + [ReplayCell(k, cell_source(theirs[k]), "rebind") for k in rebind])
    return Plan(replay, f"{len(replay)} cells replayed")


def _first_stale_read(replay, cells, code, writes, changed_at):
    """The first (replayed cell, name, cell that changes the name) where the replay, run
    after the chapter's end, would not find the name as it was at that cell's position;
    None if there is none."""
    again = {r.index for r in replay}
    for r in replay:
        c = cells[r.index]
        for x in sorted(c.reads & changed_at[r.index] if r.kind == "grader" else c.reads):
            before = [k for k in code if k < r.index and x in writes[k]]
            fresh = [k for k in before if x in cells[k].must]
            if fresh and all(k in again for k in before if k >= fresh[-1]):
                continue  # the replay binds x anew before it, and does all that changes it since
            later = [j for j in code if j >= r.index and x in writes[j]]
            if not later and not again.intersection(before):
                continue  # the chapter's end holds x as it was here, and the replay leaves it alone
            return r, x, (later or [k for k in before if k in again])[0]
    return None
