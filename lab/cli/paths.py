"""Checks every command makes on the files it is given, before it starts any work.

* :func:`check_paths` refuses an output that is one of the command's inputs, or that
  collides with another of its outputs (sidecars and journals included), comparing
  resolved paths -- so ``train D.csv --out D.csv`` can never overwrite the data;
* :func:`check_writable` makes sure an output can be written where it is asked for (not a
  directory, a parent that is a directory, a writable place), so that a long run never
  fails at its very end with all its work lost.

Both raise :class:`lab.errors.InputError` (exit code 2) naming the flag and the path.
"""

from __future__ import annotations

import contextlib
import os
import signal
import tempfile
from pathlib import Path

from lab.errors import InputError
from lab.files import exclusive_lock

__all__ = ["check_paths", "check_writable", "dataset_outputs", "existing", "output_lock", "ignore_file_size_signal"]


def _key(path) -> Path:
    return Path(os.path.abspath(os.path.expanduser(str(path)))).resolve()


def dataset_outputs(flag: str, path) -> dict:
    """The files a dataset output ``path`` writes: the CSV and its ``.json`` sidecar."""
    return {flag: path, f"{flag} sidecar": f"{path}.json"}


def check_paths(inputs: dict, outputs: dict) -> None:
    """``inputs`` / ``outputs``: {what (e.g. "--out", "DATA"): path or None}. Raises
    InputError if an output is an input or two outputs are the same file."""
    ins = {what: _key(p) for what, p in inputs.items() if p is not None}
    seen: dict[Path, str] = {}
    for what, p in outputs.items():
        if p is None:
            continue
        key = _key(p)
        for in_what, in_key in ins.items():
            if key == in_key:
                raise InputError(
                    f"{what} {p} is the input {in_what}: refusing to overwrite an input; choose another path"
                )
        if key in seen:
            raise InputError(f"{what} {p} is the same file as {seen[key]}: choose different paths")
        seen[key] = what


def check_writable(path, what: str = "--out") -> None:
    """Raise InputError unless a file can be written (atomically) at ``path``: it is not a
    directory, its nearest existing ancestor is a writable directory. Missing parents are
    created only when the output is written, so a refused run leaves nothing behind."""
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{what} {path} is a directory; give a file name")
    parent = p.parent if str(p.parent) else Path(".")
    for ancestor in [parent, *parent.parents]:
        if ancestor.exists():
            if not ancestor.is_dir():
                raise InputError(f"{what} {path}: {ancestor} is a file, not a directory")
            break
    try:
        if ancestor == parent:
            with tempfile.NamedTemporaryFile(dir=parent, prefix=f".{p.name}.", suffix=".probe"):
                pass
        elif not os.access(ancestor, os.W_OK | os.X_OK):
            raise PermissionError(13, "Permission denied")
    except OSError as err:
        raise InputError(f"{what} {path}: cannot write in {ancestor} ({err.strerror or err})") from None


def existing(arg) -> str | None:
    """``arg`` if it names an existing file or directory (a robot given by path), else None."""
    return str(arg) if arg is not None and Path(str(arg)).exists() else None


@contextlib.contextmanager
def output_lock(path, what: str = "--out"):
    """Hold ``PATH.lock`` while a command writes ``path``: a second run with the same output
    is refused at once (InputError) instead of both working to the end and colliding."""
    lock_file = Path(f"{path}.lock")
    lock_file.parent.mkdir(parents=True, exist_ok=True)  # the run starts writing here
    with exclusive_lock(lock_file, f"{what} {path} is being written by another run (lock {lock_file}); wait for it"):
        yield


def ignore_file_size_signal() -> None:
    """Let a write past the file-size limit (``ulimit -f``) fail with an OSError that is
    reported and cleaned up, instead of SIGXFSZ killing the process mid-write."""
    if hasattr(signal, "SIGXFSZ"):
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
