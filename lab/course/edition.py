"""The student edition of the course: the chapters with the exercises' solutions removed.

A chapter's exercise is a function the student writes in a code cell tagged ``solution``
(the source notebooks hold the reference solution). :func:`student_edition` keeps only
the signatures and docstrings of those functions, each body replaced by
``raise NotImplementedError``, and clears every output, so the graders say "not
implemented yet" until the student has written the function.

:func:`build_student_edition` writes the whole course (chapter 00 included) into a folder
the student then works in (``build/student/``: ``scripts/jupyter --student``,
``scripts/student-edition``), and never overwrites the student's work. A manifest in that
folder (``.student-edition.json``) records every notebook as written: the SHA-256 of its
bytes and of its cells (:func:`lab.course.student_work.cells_key`). A notebook counts as
edited when its cells differ from what was written: a cell's source or type changed, a
cell added or removed. Opening it in JupyterLab, running it or letting JupyterLab autosave
it is not an edit (outputs, execution counts and metadata are not compared). On a rebuild
an unedited notebook is refreshed when its chapter changed (the outputs of cells the
student ran go with it: running them again makes them again) and left alone otherwise; an
edited one (or one the manifest does not know) is kept as it is, and when its chapter
changed the new edition goes beside it as ``NN_name.updated.ipynb``. Each file is looked at
once more just before it is replaced: one saved while the build ran is kept as saved, its
new edition beside it. One build at a time (a lock); every file is written atomically.
"""

from __future__ import annotations

import contextlib
import json
import re
from pathlib import Path

from lab.course.stubs import stub_source
from lab.course.student_work import cells_key, look, replace_unless_changed, sha256_of
from lab.errors import InputError
from lab.files import atomic_write_text, exclusive_lock

__all__ = [
    "student_edition",
    "edition_text",
    "build_student_edition",
    "SOLUTION_TAG",
    "GRADER_TAG",
    "MANIFEST",
]

SOLUTION_TAG, GRADER_TAG = "solution", "grader"
#: The build's record of what it wrote, and its lock, in the edition's folder.
MANIFEST, LOCK = ".student-edition.json", ".student-edition.lock"
#: A chapter's file name: two digits, an underscore, a name (not ``01_x.updated.ipynb``).
CHAPTER_NAME = re.compile(r"\d\d_[\w-]+\.ipynb")
#: The end of the name of a chapter's new edition put beside the student's.
UPDATED = re.compile(r"\.updated(-\d+)?\.ipynb$")


def edition_text(source: str | Path, up: str = "") -> tuple[str, int]:
    """The student edition of notebook ``source`` as the text of an ``.ipynb`` file, and the
    number of stubbed (solution) cells. ``up``: see :func:`student_edition`.
    :class:`~lab.errors.InputError` naming the file for a notebook that is not JSON, not
    a notebook, or whose solution cell is not Python."""
    try:
        nb = json.loads(Path(source).read_text())
        n = sum(_edit_cell(cell, up) for cell in nb["cells"])
    except InputError as e:
        raise InputError(f"{source}: {e}") from None
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
        raise InputError(f"{source}: not a notebook ({type(e).__name__}: {e})") from None
    return json.dumps(nb, indent=1, ensure_ascii=False) + "\n", n


def _edit_cell(cell: dict, up: str) -> bool:
    """Clear a code cell's outputs, move its parameters ``up``, stub it if it is a solution;
    True for a solution cell."""
    if cell["cell_type"] != "code":
        return False
    cell["outputs"], cell["execution_count"] = [], None
    tags = cell.get("metadata", {}).get("tags", [])
    if up and "parameters" in tags:
        text = "".join(cell["source"]).replace('"../', f'"{up}../')
        cell["source"] = text.splitlines(keepends=True)
    if SOLUTION_TAG in tags:
        cell["source"] = stub_source("".join(cell["source"])).splitlines(keepends=True)
        return True
    return False


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


def _read_manifest(out: Path) -> tuple[dict, list[str]]:
    """The manifest: ``files`` ({name: [SHA-256 of the file's bytes, ...]}: what this command
    wrote there), ``cells`` ({name: [:func:`cells_key`, ...]}: the same files' cells; absent
    from a manifest of an older build) and ``chapters`` ({name: SHA-256 of the last edition
    made}); an unreadable one counts as empty."""
    path = out / MANIFEST
    empty = {"files": {}, "cells": {}, "chapters": {}}
    if not path.exists():
        return empty, []
    try:
        data = json.loads(path.read_text())
        files, chapters, cells = dict(data["files"]), dict(data["chapters"]), dict(data.get("cells", {}))
    except (OSError, ValueError, KeyError, TypeError):
        return empty, [f"{path}: unreadable; every notebook already in {out} counts as yours and is kept"]
    return {"files": files, "cells": cells, "chapters": chapters}, []


def _write_manifest(out: Path, manifest: dict) -> None:
    body = {"format": "lab student edition", "version": 1, **manifest}
    atomic_write_text(out / MANIFEST, json.dumps(body, indent=1, sort_keys=True) + "\n")


def _not_json(data: bytes) -> str:
    """ " (not valid JSON: ...)" for a file that does not parse as JSON, else ""."""
    try:
        json.loads(data)
    except (ValueError, UnicodeDecodeError) as e:
        return f" (not valid JSON: {e})"
    return ""


def _ours(name: str, data: bytes | None, manifest: dict) -> bool:
    """Whether this command wrote file ``name`` as it is (``data``) and the student wrote
    nothing in it since: its cells are as written (opened, run or autosaved by JupyterLab
    is not an edit), or, for a file an older build recorded by its bytes only, its bytes."""
    if data is None:
        return False
    return cells_key(data) in manifest["cells"].get(name, []) or sha256_of(data) in manifest["files"].get(name, [])


def _beside(target: Path, manifest: dict, taken=()) -> Path:
    """Where the new edition of an edited ``target`` goes: ``NAME.updated.ipynb`` (then
    ``-2``, ``-3``, ...), the first that does not exist or that this command wrote and
    nobody edited since, and is not in ``taken``."""
    for k in range(1, 1000):
        path = target.with_name(f"{target.stem}.updated{'' if k == 1 else f'-{k}'}.ipynb")
        if path not in taken and (not path.exists() or _ours(path.name, look(path).data, manifest)):
            return path
    raise InputError(f"{target.parent}: 999 updated editions of {target.name} already; move some away")


def _plan(chapters: list[Path], out: Path, up: str, manifest: dict):
    """What to write (``{path: (text, Seen)}``: the new text and the file as it was when
    the decision was made) and what to say, for each chapter."""
    writes, said, made = {}, [], {}
    counts = dict.fromkeys(("new", "refreshed", "unchanged", "kept"), 0)
    for src in chapters:
        text, _ = edition_text(src, up)
        new, target = sha256_of(text), out / src.name
        if target.is_dir():
            raise InputError(f"{target}: a folder where the student edition puts this chapter; move it away")
        seen = look(target)
        same_cells = seen.data is not None and cells_key(seen.data) == cells_key(text)
        if seen.data is None:
            writes[target] = (text, seen)
            counts["new"] += 1
        elif sha256_of(seen.data) == new or (same_cells and manifest["chapters"].get(src.name) == new):
            counts["unchanged"] += 1  # as written, or only opened, run or autosaved since
            _remember_cells(manifest, src.name, text)  # (a manifest of an older build has no cells)
        elif _ours(src.name, seen.data, manifest):
            writes[target] = (text, seen)
            counts["refreshed"] += 1
        elif same_cells:  # no record of writing it, but its cells are the new edition's
            counts["unchanged"] += 1
            _remember_cells(manifest, src.name, text)
        else:
            counts["kept"] += 1
            why = "edited since it was written" if src.name in manifest["files"] else "no record of writing it"
            line = f"{target}: kept as it is ({why}){_not_json(seen.data)}"
            if manifest["chapters"].get(src.name) != new:
                alt = _beside(target, manifest, writes)
                writes[alt] = (text, look(alt))
                line += f"; the chapter changed: its new edition is {alt}"
            said.append(line)
        made[src.name] = new
    return writes, said, counts, made


def _write(out: Path, writes: dict, manifest: dict, counts: dict) -> list[str]:
    """Write each planned file unless it changed since the plan looked at it: a save from
    JupyterLab while the edition was being built. A save that only touched what is not the
    student's (an autosave of a notebook opened) is replaced all the same; after any other,
    the file stays as saved and its new edition goes beside it. Returns a line for each."""
    said = []
    for path, (text, seen) in writes.items():
        chapter = path.with_name(UPDATED.sub(".ipynb", path.name))
        for tries in range(100):
            if replace_unless_changed(path, text, seen):
                break
            now = look(path)
            if tries < 3 and _ours(path.name, now.data, manifest):
                seen = now
                continue
            alt = _beside(chapter, manifest, [*writes, path])
            said.append(f"{path}: saved while the edition was being built; kept as saved, its new edition is {alt}")
            if path == chapter:
                counts["refreshed" if seen.data is not None else "new"] -= 1
                counts["kept"] += 1
            _remember(manifest, alt.name, text)
            _write_manifest(out, manifest)
            path, seen = alt, look(alt)
        else:
            raise InputError(f"{chapter}: its new editions keep changing while they are written; stop what saves them")
        manifest["files"][path.name], manifest["cells"][path.name] = [sha256_of(text)], [cells_key(text)]
    return said


def _remember(manifest: dict, name: str, text: str) -> None:
    """Record ``text`` as one this command writes to ``name`` (before writing it)."""
    manifest["files"][name] = sorted({*manifest["files"].get(name, []), sha256_of(text)})
    _remember_cells(manifest, name, text)


def _remember_cells(manifest: dict, name: str, text: str) -> None:
    """Record the cells of ``text`` as this command's in ``name``: a file that has them
    holds nothing the student wrote."""
    manifest["cells"][name] = sorted({*manifest["cells"].get(name, []), cells_key(text)})


def build_student_edition(notebooks: str | Path, out: str | Path, up: str = "../") -> list[str]:
    """Write the student edition of every chapter ``notebooks/NN_*.ipynb`` into ``out``,
    keeping the student's work.

    A notebook in ``out`` whose cells are as the manifest recorded them written is
    refreshed; any other is the student's and is never overwritten, not even when it is
    saved while this runs (see the module's docstring).

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
        # Record what is about to be written first: a build killed in between leaves each
        # file either as it was or as written, and both count as ours next time.
        for path, (text, _) in writes.items():
            _remember(manifest, path.name, text)
        _write_manifest(out, manifest)
        kept += _write(out, writes, manifest, counts)
        manifest["chapters"].update(made)  # only now: an interrupted build makes them again
        _write_manifest(out, manifest)
    summary = ", ".join(f"{n} {what}" for what, n in counts.items() if n)
    return [*said, *kept, f"student edition in {out}/: {len(chapters)} notebooks ({summary})"]
