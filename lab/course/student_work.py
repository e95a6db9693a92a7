"""What the student wrote in a notebook of the student edition, and writing beside it safely.

The student edition (:mod:`lab.course.edition`) must tell a notebook the student worked in
from one they only opened. The file's bytes cannot tell: JupyterLab marks a notebook dirty
as it opens and its autosave adds ``metadata.language_info``; it may also renumber the
format's minor version, add cell ids and store the outputs and execution counts of the
cells the student ran. None of that is the student's writing. :func:`cells_key` is a
digest of what is: each cell's type, source and attachments (a picture pasted into a
Markdown cell), in order, so a changed, added, removed or retyped cell is an edit and
everything else is not. Outputs are deliberately left out: they are what the given code
printed when the student ran it, and running it again makes them again.

The edition is rebuilt while JupyterLab may still be open on it, and an autosave can land
at any moment. :func:`look` records a file as read (its inode, size, modification time and
bytes); :func:`replace_unless_changed` writes the new text to a temporary file first, then
reads the target once more and renames the new text over it only if it is still exactly as
read, so a save made after the edition decided what to write is never replaced. What is
left is the moment between that last reading and the rename (microseconds, no file I/O
in between); JupyterLab, which checks a file's modification time before it saves, then
warns the student that the file changed on disk instead of saving over it silently.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from pathlib import Path
from typing import NamedTuple

__all__ = ["Seen", "cells_key", "look", "replace_unless_changed", "sha256_of"]


class Seen(NamedTuple):
    """A file as it was read: ``stat`` (inode, size, modification time in ns) and ``data``
    (its bytes); both ``None`` for a file that did not exist."""

    stat: tuple | None
    data: bytes | None


def sha256_of(data: str | bytes) -> str:
    """The SHA-256 of text (UTF-8) or bytes, in hex.

    Parameters
    ----------
    data : str or bytes
        What to digest.

    Returns
    -------
    str
        64 hex digits.
    """
    return hashlib.sha256(data.encode() if isinstance(data, str) else data).hexdigest()


def _source(value) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, list) and all(isinstance(s, str) for s in value):
        return "".join(value)
    raise TypeError("a cell's source is neither text nor a list of lines")


def cells_key(data: str | bytes | None) -> str | None:
    """A digest of what the student can write in notebook ``data``: every cell's type,
    source and attachments, in order (not the metadata, cell ids, execution counts or
    outputs, which JupyterLab and running the cells change).

    Parameters
    ----------
    data : str, bytes or None
        The notebook file's content (``.ipynb`` JSON).

    Returns
    -------
    str or None
        64 hex digits; ``None`` for ``None`` or for a file that is not a notebook.
    """
    if data is None:
        return None
    try:
        cells = json.loads(data)["cells"]
        body = [[c.get("cell_type"), _source(c.get("source", "")), c.get("attachments") or {}] for c in cells]
        text = json.dumps(body, sort_keys=True, ensure_ascii=False)
    except (ValueError, KeyError, TypeError, AttributeError):  # not JSON, not a notebook, a cell not a dict
        return None
    return sha256_of(text)


def look(path: str | Path) -> Seen:
    """Read ``path`` as it is now.

    Parameters
    ----------
    path : str or pathlib.Path
        A file, or a path where none exists.

    Returns
    -------
    Seen
        Its stat (inode, size, modification time in ns) taken before its bytes, so a save
        between the two makes the file differ from what was seen the next time it is
        looked at, never the other way.
    """
    try:
        st = os.stat(path)
        return Seen((st.st_ino, st.st_size, st.st_mtime_ns), Path(path).read_bytes())
    except FileNotFoundError:
        return Seen(None, None)


def replace_unless_changed(path: str | Path, text: str, seen: Seen) -> bool:
    """Write ``text`` to ``path`` atomically, but only if ``path`` is still as ``seen``.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to replace (or create, when ``seen`` says it did not exist).
    text : str
        Its new content.
    seen : Seen
        What :func:`look` returned when the caller decided to replace it.

    Returns
    -------
    bool
        True when written; False (nothing written, no temporary file left) when the file
        changed since it was seen: someone saved to it in the meantime.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        with open(tmp, "w", newline="") as fh:  # the slow part first, then the last check
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        if look(path) != seen:
            return False
        os.replace(tmp, path)
        return True
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
