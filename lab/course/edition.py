"""The student edition of the course: the chapters with the exercises' solutions removed.

A chapter's exercise is a function the student writes in a code cell tagged ``solution``
(the source notebooks hold the reference solution). :func:`student_edition` keeps only
the signatures and docstrings of those functions, each body replaced by
``raise NotImplementedError``, and clears every output, so the graders say "not
implemented yet" until the student has written the function.

:func:`build_student_edition` writes the whole course (chapter 00 included) into a folder
the student then works in (``build/student/``: ``scripts/jupyter --student``,
``scripts/student-edition``), and never overwrites the student's work. A manifest in that
folder (``.student-edition.json``) records the SHA-256 of every notebook as written. On a
rebuild an unedited notebook is refreshed; an edited one (or one the manifest does not
know) is kept as it is, and when its chapter changed the new edition goes beside it as
``NN_name.updated.ipynb``. One build at a time (a lock); every file is written atomically.
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
import json
import re
from pathlib import Path

from lab.errors import InputError
from lab.files import atomic_write_text, exclusive_lock

__all__ = [
    "student_edition",
    "edition_text",
    "build_student_edition",
    "stub_source",
    "SOLUTION_TAG",
    "GRADER_TAG",
    "MANIFEST",
]

SOLUTION_TAG, GRADER_TAG = "solution", "grader"
#: The build's record of what it wrote, and its lock, in the edition's folder.
MANIFEST, LOCK = ".student-edition.json", ".student-edition.lock"
#: A chapter's file name: two digits, an underscore, a name (not ``01_x.updated.ipynb``).
CHAPTER_NAME = re.compile(r"\d\d_[\w-]+\.ipynb")


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
        ``raise NotImplementedError``; everything else dropped.
    """
    tree = ast.parse(source)
    lines = source.splitlines()
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


def edition_text(source: str | Path, up: str = "") -> tuple[str, int]:
    """The student edition of notebook ``source`` as the text of an ``.ipynb`` file, and the
    number of stubbed (solution) cells. ``up``: see :func:`student_edition`.
    :class:`~lab.errors.InputError` naming the file for a notebook that is not JSON."""
    try:
        nb = json.loads(Path(source).read_text())
        cells = nb["cells"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise InputError(f"{source}: not a notebook ({type(e).__name__}: {e})") from None
    n = 0
    for cell in cells:
        if cell["cell_type"] != "code":
            continue
        cell["outputs"], cell["execution_count"] = [], None
        if up and "parameters" in cell.get("metadata", {}).get("tags", []):
            text = "".join(cell["source"]).replace('"../', f'"{up}../')
            cell["source"] = text.splitlines(keepends=True)
        if SOLUTION_TAG in cell.get("metadata", {}).get("tags", []):
            cell["source"] = stub_source("".join(cell["source"])).splitlines(keepends=True)
            n += 1
    return json.dumps(nb, indent=1, ensure_ascii=False) + "\n", n


def student_edition(source: str | Path, target: str | Path, up: str = "") -> int:
    """Write the student edition of notebook ``source`` to ``target`` (solution cells
    stubbed, outputs cleared), atomically.

    Parameters
    ----------
    source, target : notebook paths (``.ipynb``).
    up : "../" per extra directory level of ``target`` below the repository compared with
        ``source``; put in front of the parameters cell's relative paths, so ``"../data/..."``
        still finds the data.

    Returns
    -------
    The number of stubbed (solution) cells.
    """
    text, n = edition_text(source, up)
    atomic_write_text(target, text)
    return n


def _sha256(text: str | bytes) -> str:
    return hashlib.sha256(text.encode() if isinstance(text, str) else text).hexdigest()


def _read_manifest(out: Path) -> tuple[dict, list[str]]:
    """The manifest's ``files`` ({name: [sha256, ...]}: what this command wrote there) and
    ``chapters`` ({name: sha256 of the last edition made}); an unreadable one counts as empty."""
    path = out / MANIFEST
    empty = {"files": {}, "chapters": {}}
    if not path.exists():
        return empty, []
    try:
        data = json.loads(path.read_text())
        files, chapters = dict(data["files"]), dict(data["chapters"])
    except (OSError, ValueError, KeyError, TypeError):
        return empty, [f"{path}: unreadable; every notebook already in {out} counts as yours and is kept"]
    return {"files": files, "chapters": chapters}, []


def _write_manifest(out: Path, manifest: dict) -> None:
    body = {"format": "lab student edition", "version": 1, **manifest}
    atomic_write_text(out / MANIFEST, json.dumps(body, indent=1, sort_keys=True) + "\n")


def _not_json(path: Path) -> str:
    """ " (not a notebook: ...)" for a file that does not parse as JSON, else ""."""
    try:
        json.loads(path.read_bytes())
    except (ValueError, UnicodeDecodeError) as e:
        return f" (not valid JSON: {e})"
    return ""


def _beside(target: Path, files: dict) -> Path:
    """Where the new edition of an edited ``target`` goes: ``NAME.updated.ipynb`` (then
    ``-2``, ``-3``, ...), the first that does not exist or that this command wrote and
    nobody edited since."""
    for k in range(1, 1000):
        path = target.with_name(f"{target.stem}.updated{'' if k == 1 else f'-{k}'}.ipynb")
        if not path.exists() or _sha256(path.read_bytes()) in files.get(path.name, []):
            return path
    raise InputError(f"{target.parent}: 999 updated editions of {target.name} already; move some away")


def _plan(chapters: list[Path], out: Path, up: str, manifest: dict):
    """What to write (``{path: text}``) and what to say, for each chapter."""
    files, writes, said, made = manifest["files"], {}, [], {}
    counts = dict.fromkeys(("new", "refreshed", "unchanged", "kept"), 0)
    for src in chapters:
        text, _ = edition_text(src, up)
        new, target = _sha256(text), out / src.name
        if target.is_dir():
            raise InputError(f"{target}: a folder where the student edition puts this chapter; move it away")
        have = _sha256(target.read_bytes()) if target.exists() else None
        if have is None or (have != new and have in files.get(src.name, [])):
            writes[target] = text
            counts["refreshed" if have else "new"] += 1
        elif have == new:
            counts["unchanged"] += 1
        else:
            counts["kept"] += 1
            why = "edited since it was written" if src.name in files else "no record of writing it: counted as yours"
            line = f"{target}: kept as it is ({why}){_not_json(target)}"
            if manifest["chapters"].get(src.name) != new:
                writes[alt := _beside(target, files)] = text
                line += f"; the chapter changed: its new edition is {alt}"
            said.append(line)
        made[src.name] = new
    return writes, said, counts, made


def build_student_edition(notebooks: str | Path, out: str | Path, up: str = "../") -> list[str]:
    """Write the student edition of every chapter ``notebooks/NN_*.ipynb`` into ``out``,
    keeping the student's work.

    A notebook in ``out`` whose SHA-256 is one the manifest recorded as written is
    refreshed; any other is the student's and is never overwritten (see the module's
    docstring).

    Parameters
    ----------
    notebooks : str or pathlib.Path
        The folder of the source chapters.
    out : str or pathlib.Path
        The edition's folder (created); must not be ``notebooks``.
    up : str
        See :func:`student_edition` ("../" for ``build/student`` beside ``notebooks``).

    Returns
    -------
    list of str
        What happened: one line per kept notebook and a summary line last.

    Raises
    ------
    InputError
        When another build holds the lock, for a source that is not a notebook, or when
        ``out`` is the source folder.
    """
    notebooks, out = Path(notebooks), Path(out)
    chapters = sorted(p for p in notebooks.glob("[0-9][0-9]_*.ipynb") if CHAPTER_NAME.fullmatch(p.name))
    if not chapters:
        raise InputError(f"{notebooks}: no chapter notebooks (NN_name.ipynb) to build the student edition from")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"{out}: cannot hold the student edition ({e.strerror})") from None
    if out.resolve() == notebooks.resolve():
        raise InputError(f"{out}: the student edition would overwrite the source chapters; choose another folder")
    with exclusive_lock(out / LOCK, f"{out} is being built by another run (lock {out / LOCK}); wait for it"):
        for stale in out.glob(".*.tmp[0-9]*"):  # a killed build's temporary file (lab.files)
            with contextlib.suppress(OSError):
                stale.unlink()
        manifest, said = _read_manifest(out)
        writes, kept, counts, made = _plan(chapters, out, up, manifest)
        # Record the hashes about to be written first: a build killed in between leaves
        # each file either as it was or as written, and both count as ours next time.
        for path, text in writes.items():
            manifest["files"][path.name] = sorted({*manifest["files"].get(path.name, []), _sha256(text)})
        _write_manifest(out, manifest)
        for path, text in writes.items():
            atomic_write_text(path, text)
            manifest["files"][path.name] = [_sha256(text)]
        manifest["chapters"].update(made)  # only now: an interrupted build makes them again
        _write_manifest(out, manifest)
    summary = ", ".join(f"{n} {what}" for what, n in counts.items() if n)
    return [*said, *kept, f"student edition in {out}/: {len(chapters)} notebooks ({summary})"]
