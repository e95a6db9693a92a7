"""Where MKL's runtime library is, found without walking the environment's folders.

``pypardiso`` finds ``libmkl_rt`` by reading its ``PYPARDISO_MKL_RT`` environment
variable, else with :func:`ctypes.util.find_library` (which runs ``ldconfig``), else by a
recursive glob of the whole environment: on this project's virtual environment (~67k
files) about a second of CPU time, paid twice (``import pypardiso`` builds a solver of its
own) in every process that factorises: each worker, notebook kernel and command.

:func:`point_pypardiso_at_mkl` looks where the ``mkl`` wheel (or conda package) puts the
library instead -- the environment's ``lib`` folder (``Library/bin`` on Windows, no
recursion), else the files the ``mkl`` distribution's metadata lists -- and sets
``PYPARDISO_MKL_RT`` to it (unless already set) before ``pypardiso`` is imported. Where
neither finds it, ``pypardiso`` searches as before.
"""

from __future__ import annotations

import glob
import os
import sys
from pathlib import Path

__all__ = ["ENV_VAR", "mkl_rt_path", "point_pypardiso_at_mkl"]

#: The environment variable ``pypardiso`` reads the library's path from.
ENV_VAR = "PYPARDISO_MKL_RT"


def _is_mkl_rt(name: str) -> bool:
    """``libmkl_rt.so.3``, ``libmkl_rt.2.dylib``, ``mkl_rt.2.dll``, ..."""
    return name.startswith(("libmkl_rt.", "mkl_rt.")) and (".so" in name or name.endswith((".dylib", ".dll")))


def _from_metadata() -> list[Path]:
    """The runtime libraries the installed ``mkl`` distribution's file list names."""
    from importlib import metadata

    try:
        files = metadata.files("mkl") or []
    except metadata.PackageNotFoundError:
        return []
    return [Path(f.locate()) for f in files if _is_mkl_rt(f.name)]


def mkl_rt_path() -> str | None:
    """The path of MKL's runtime library in this Python environment, without a directory walk.

    Looks in ``sys.prefix``'s ``lib`` and ``Library/bin`` folders (not below them), then
    in the file list of the ``mkl`` distribution's metadata; the shortest existing path
    wins, as in ``pypardiso``'s own search.

    Returns
    -------
    str or None
        The absolute path of ``libmkl_rt`` (e.g. ``.venv/lib/libmkl_rt.so.3``), or None
        where neither place has it.
    """
    folders = [Path(sys.prefix) / "lib", Path(sys.prefix) / "Library" / "bin"]
    found = [Path(p) for d in folders for p in glob.glob(glob.escape(str(d)) + "/*mkl_rt*") if _is_mkl_rt(Path(p).name)]
    if not found:
        found = _from_metadata()
    found = sorted((p.resolve() for p in found if p.is_file()), key=lambda p: len(str(p)))
    return str(found[0]) if found else None


def point_pypardiso_at_mkl() -> str | None:
    """Set ``PYPARDISO_MKL_RT`` to :func:`mkl_rt_path` unless it is set already.

    Call before the first ``import pypardiso``. The variable is inherited by the worker
    processes started afterwards (which find the same path themselves anyway).

    Returns
    -------
    str or None
        The path ``pypardiso`` will load (the one already set, or the one found), or None
        where none was found (``pypardiso`` then searches on its own).
    """
    if os.environ.get(ENV_VAR):
        return os.environ[ENV_VAR]
    path = mkl_rt_path()
    if path is not None:
        os.environ[ENV_VAR] = path
    return path
