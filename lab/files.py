"""Small file helpers every stage shares: atomic writes, JSON encoding, the code version.

Files the package writes are never left half-written: :func:`atomic_open` writes to a
temporary file in the same directory, fsyncs it and renames it over the target only when
the writing finished; on any failure the temporary file is removed and the target is
untouched.
"""

from __future__ import annotations

import contextlib
import os
import stat
import subprocess
from pathlib import Path

import numpy as np

__all__ = [
    "atomic_open",
    "atomic_write_text",
    "atomic_write_group",
    "json_default",
    "code_version",
    "remove_and_release",
    "exclusive_lock",
    "format_bytes",
]


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w"):
    """Open a temporary file next to ``path`` for writing; on a clean exit it is flushed,
    fsynced and renamed to ``path``, on an exception it is removed.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write (its folder is created).
    mode : str
        "w" (text, no newline translation) or "wb".

    Yields
    ------
    file object
        The open temporary file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        with open(tmp, mode, **({"newline": ""} if "b" not in mode else {})) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write text to a file atomically (see :func:`atomic_open`).

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write.
    text : str
        Its whole content.
    """
    with atomic_open(path) as fh:
        fh.write(text)


def atomic_write_group(files: dict) -> None:
    """Write several files that belong together (a dataset and its sidecar) all or none:
    every one is written to a temporary file first and only when all of them are complete
    are they renamed over their targets, in the order given (put the primary file last).
    On any failure (a full disk, say) the temporaries are removed and every target is left
    as it was.

    Parameters
    ----------
    files : dict
        {path: str or bytes}, in the order to rename.
    """
    tmps = []
    try:
        for path, content in files.items():
            path = Path(path)
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
            tmps.append((tmp, path))
            with open(tmp, "wb") as fh:
                fh.write(content.encode() if isinstance(content, str) else content)
                fh.flush()
                os.fsync(fh.fileno())
        for tmp, path in tmps:
            os.replace(tmp, path)
    finally:
        for tmp, _ in tmps:
            if tmp.exists():
                tmp.unlink()


def json_default(obj):
    """``json.dumps(..., default=json_default)``: NumPy arrays and scalars as lists and numbers.

    Parameters
    ----------
    obj : object
        What ``json`` cannot serialise itself.

    Returns
    -------
    list or int or float or bool
        ``obj`` as JSON-able Python; TypeError for anything but NumPy arrays and scalars.
    """
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {type(obj)}")


def code_version() -> str:
    """Package version plus the git commit it runs from, when known.

    Returns
    -------
    str
        E.g. ``"1.2.0+git.abc1234-dirty"``, or the version alone outside a git checkout.
    """
    from lab import __version__

    try:
        out = subprocess.run(
            ["git", "describe", "--always", "--dirty"],
            cwd=Path(__file__).parent,
            capture_output=True,
            text=True,
            timeout=5,
        )
        if out.returncode == 0:
            return f"{__version__}+git.{out.stdout.strip()}"
    except (OSError, subprocess.SubprocessError):
        pass
    return __version__


def read_csv_table(path: str | Path, columns, what: str) -> list[dict]:
    """The rows of the CSV at ``path`` as dicts of strings; :class:`lab.errors.InputError`
    naming ``what`` (e.g. "period curve") for a missing file, an empty one or one without
    every name in ``columns``."""
    import csv

    from lab.errors import InputError

    try:
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
    except FileNotFoundError:
        raise InputError(f"{what} not found: {path}") from None
    if not rows or not set(columns) <= set(rows[0]):
        raise InputError(f"{path}: not a {what} (needs the columns {list(columns)})")
    return rows


def read_resumable_rows(path: str | Path, columns, what: str) -> list[dict]:
    """The rows of a study's results CSV that a run resumes (strings), ``[]`` if ``path``
    does not exist yet; :class:`lab.errors.InputError` naming the file (and line) for a
    header other than exactly ``columns`` or a row with fewer or more fields. ``what``
    names the kind of file, e.g. "data-curve"."""
    import csv

    from lab.errors import InputError

    path = Path(path)
    if not path.exists():
        return []
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        if reader.fieldnames is None or tuple(reader.fieldnames) != tuple(columns):
            raise InputError(f"{path}: not a {what} file (columns {reader.fieldnames}); choose another output file")
        rows = list(reader)
    for line, r in enumerate(rows, start=2):
        if None in r or None in r.values():
            raise InputError(
                f"{path}: line {line} does not have the {len(columns)} columns; choose another output file"
            )
    return rows


def remove_and_release(lock) -> None:
    """Release a held ``filelock`` lock, removing its file first where that is safe.

    The lock is filelock's ``UnixFileLock``: an ``flock`` on the file's inode, taken with
    ``timeout=0``, so no writer ever waits for it. The file is unlinked while the lock is
    still held, then released. A second writer that opened the file before the unlink
    either tries its ``flock`` while we hold it (refused at once) or after our release, on
    an inode without a name, which filelock (4.2.11, as pinned) checks (``st_nlink == 0``)
    and does not count as acquired (refused too); any later writer creates a new file.
    The other order -- release, then unlink -- would be a race: a writer could take the
    lock in between and lose its file, and a third would then lock a new file beside it.
    Other locks (Windows, the soft fallback) are left as filelock leaves them.

    Parameters
    ----------
    lock : filelock.BaseFileLock
        A lock this process holds.
    """
    from filelock import UnixFileLock

    if isinstance(lock, UnixFileLock) and lock.is_locked:
        with contextlib.suppress(OSError):  # left behind, it is harmless
            os.unlink(lock.lock_file)
    lock.release()


@contextlib.contextmanager
def exclusive_lock(lock_file: str | Path, busy: str):
    """Hold ``lock_file`` while one writer works; a second is refused at once with
    ``InputError(busy)`` instead of waiting or colliding. The file is removed when done
    (see :func:`remove_and_release`) if this run created it; one that was there before (an
    empty file: a killed run's lock) is left as it was. A file by that name that cannot be
    a lock -- it holds data, or it is a link, a directory, a pipe -- is refused
    (InputError) and never touched: it is someone's file, not a lock.

    Parameters
    ----------
    lock_file : str or pathlib.Path
        The lock's file.
    busy : str
        The message of the error a second writer gets.

    Yields
    ------
    None
        While the lock is held.
    """
    from filelock import FileLock, Timeout

    from lab.errors import InputError

    try:
        st = os.lstat(lock_file)
    except FileNotFoundError:
        st = None
    if st is not None and (not stat.S_ISREG(st.st_mode) or st.st_size > 0):
        what = f"{st.st_size} bytes of data" if stat.S_ISREG(st.st_mode) else "not a plain file"
        raise InputError(
            f"{lock_file} exists and is not a lock file ({what}): a run takes that name as its lock and "
            "would remove it; move the file away or write the output elsewhere"
        )
    lock = FileLock(lock_file, timeout=0)
    try:
        lock.acquire()
    except Timeout:
        raise InputError(busy) from None
    try:
        yield
    finally:
        if st is None:
            remove_and_release(lock)
        else:
            lock.release()


def format_bytes(n: float) -> str:
    """A number of bytes in words, in decimal units, for memory refusals.

    Parameters
    ----------
    n : float
        Bytes.

    Returns
    -------
    str
        E.g. "3.6 TB".
    """
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 1000:
            return f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} PB"
