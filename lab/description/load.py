"""Finding and reading robot description files.

Shipped descriptions live in ``lab/robots/<name>.toml``; :func:`load_robot` accepts either
such a name (``"three-cable"``) or a path to a user's own file, whose ``body.mesh_file`` is
read relative to the file's folder.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

from lab.description.parse import parse_robot
from lab.description.robot import DescriptionError, RobotDescription

ROBOTS_DIR = Path(__file__).resolve().parent.parent / "robots"


def read_toml(path: str | Path, error: type[Exception], what: str) -> dict:
    """Parse a TOML file, naming the file in any error.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    error : type
        The exception raised for a missing or malformed file.
    what : str
        Which kind of file it is, for the message (e.g. ``"defects file"``).

    Returns
    -------
    dict
        The parsed document.
    """
    try:
        return tomllib.loads(Path(path).read_bytes().decode("utf-8"))
    except FileNotFoundError:
        raise error(f"{what} not found: {path}") from None
    except IsADirectoryError:
        raise error(f"{what} {path} is a directory, not a file") from None
    except UnicodeDecodeError as err:
        raise error(
            f"{path}: not a TOML {what} (not UTF-8 text: byte {err.start} is 0x{err.object[err.start]:02x})"
        ) from None
    except tomllib.TOMLDecodeError as err:
        raise error(f"{path}: not valid TOML: {err}") from None


def load_robot(name_or_path: str | Path) -> RobotDescription:
    """Load a shipped robot by name or a description file by path.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A shipped robot's name (``"three-cable"``, ``"six-cable"``) or a TOML file's path.

    Returns
    -------
    RobotDescription
        The validated description (a :class:`DescriptionError` naming the file and the field otherwise).
    """
    path = Path(name_or_path)
    if not path.suffix and not path.exists():
        path = ROBOTS_DIR / f"{name_or_path}.toml"
        if not path.exists():
            raise DescriptionError(f"unknown robot {str(name_or_path)!r}; shipped robots: {shipped_robots()}")
    data = read_toml(path, DescriptionError, "robot description file")
    try:
        return parse_robot(data, base_dir=path.parent)
    except DescriptionError as err:
        raise DescriptionError(f"{path}: {err}") from None


def shipped_robots() -> list[str]:
    """The names of the shipped robot descriptions.

    Returns
    -------
    list of str
        Sorted names (the stems of ``lab/robots/*.toml``).
    """
    return sorted(p.stem for p in ROBOTS_DIR.glob("*.toml"))
