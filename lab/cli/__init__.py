"""The command line: ``python -m lab <command>`` (or ``lab <command>``), one module per command.

Each command module (:data:`COMMANDS`) has ``add_parser(subparsers, parents)`` and a short
``run(args) -> exit code`` that turns flags into the stages' typed specs (:mod:`.flags`) and
calls one library function. Command modules never import each other; :mod:`.paths`,
:mod:`.signals`, :mod:`.flags` and :mod:`.sampling` are shared helpers.

One error policy, applied here and nowhere else: a :class:`lab.errors.LabError` prints
``error: <message>`` (a :class:`lab.errors.FieldError`'s ``Class.field`` written as the flag
the user typed, :func:`.flags.flag_text`) and exits with its code -- 2 for bad input (a file, a field, an
argument), 1 for a runtime or hardware failure. An OS error on a file the user named
(missing, not permitted, a directory) is bad input too (2); other OS errors exit 1.
Ctrl-C, SIGTERM and SIGHUP stop the command cleanly (rigs closed with torque off, journals
flushed) and exit with 128 + the signal number (:mod:`.signals`). No traceback is printed
for any of these unless ``--debug`` is given; an unexpected exception still shows one.
"""

from __future__ import annotations

import argparse
import sys
import traceback

from lab.cli import (
    calibrate,
    capture,
    compare,
    data_curve,
    defects,
    fit_dynamics,
    import_data,
    inspect,
    simulate,
    splits,
    track,
    train,
    transfer,
    transfer_curve,
)
from lab.cli.flags import flag_label, flag_text
from lab.cli.signals import Terminated, exit_code, interrupts_as_keyboard
from lab.errors import EXIT_INPUT, EXIT_RUNTIME, FieldError, LabError

__all__ = ["main", "build_parser", "COMMANDS"]

#: The commands, in the order ``--help`` lists them.
COMMANDS = {
    "simulate": simulate,
    "import-data": import_data,
    "inspect": inspect,
    "compare": compare,
    "train": train,
    "splits": splits,
    "track": track,
    "capture": capture,
    "defects": defects,
    "transfer": transfer,
    "transfer-curve": transfer_curve,
    "data-curve": data_curve,
    "calibrate": calibrate,
    "fit-dynamics": fit_dynamics,
}

#: OS errors that mean the user named a bad path (exit 2); any other OSError exits 1.
_BAD_PATH_ERRORS = (FileNotFoundError, PermissionError, IsADirectoryError, NotADirectoryError, FileExistsError)


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``python -m lab``: ``--debug`` and one subcommand per entry of :data:`COMMANDS`.

    Returns
    -------
    argparse.ArgumentParser
        The parser; a parsed command's ``func(args)`` runs it.
    """
    debug = argparse.ArgumentParser(add_help=False)
    debug.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help="show the Python traceback of an error"
    )
    p = argparse.ArgumentParser(
        prog="python -m lab",
        description="Soft robot control with a learned "
        "differentiable model: simulate, capture, train, evaluate and track.",
    )
    p.add_argument("--debug", action="store_true", help="show the Python traceback of an error")
    sub = p.add_subparsers(dest="command", required=True)
    for module in COMMANDS.values():
        module.add_parser(sub, parents=[debug])
    return p


def _os_error_message(err: OSError) -> str:
    where = f"{err.filename}: " if err.filename else ""
    return f"{where}{err.strerror or err}"


def _of_value(err) -> bool:
    return isinstance(err, FieldError) and err.value_check


def main(argv=None) -> int:
    """Run one command under the error policy of the module docstring.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``python -m lab`` (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code: 0 success, 1 runtime failure, 2 bad input, 128 + the signal number
        when interrupted (130 for Ctrl-C).
    """
    args = build_parser().parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    try:
        with interrupts_as_keyboard():
            return args.func(args)
    except KeyboardInterrupt as err:  # Ctrl-C, SIGTERM, SIGHUP: the command has cleaned up
        if args.debug:
            traceback.print_exc()
        what = f"by {err.args[0]}" if isinstance(err, Terminated) else "(Ctrl-C)"
        print(f"interrupted {what}; stopped cleanly", file=sys.stderr)
        return exit_code(err)
    except (LabError, OSError) as err:
        if isinstance(err, LabError):  # a spec's field, ``Class.field``, named as the user's flag
            code, message = err.exit_code, flag_text(err.renamed(flag_label) if _of_value(err) else str(err))
        else:
            code = EXIT_INPUT if isinstance(err, _BAD_PATH_ERRORS) else EXIT_RUNTIME
            message = _os_error_message(err)
        if args.debug:
            traceback.print_exc()
        print(f"error: {message}", file=sys.stderr)
        return code
