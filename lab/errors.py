"""One root exception for everything the package raises on purpose, and what it means.

Every error ``lab`` raises deliberately derives from :class:`LabError`. Its
``exit_code`` is what the command line returns for it:

* :class:`InputError` -- bad input: a file, a field in it, or an argument (exit code 2).
  It is also a ``ValueError``, so ``except ValueError`` keeps working;
* :class:`LabRuntimeError` -- the work itself failed: a solver that did not converge, a
  servo or motion-capture failure (exit code 1). It is also a ``RuntimeError``.

``python -m lab`` prints ``error: <message>`` for either, without a traceback unless
``--debug`` is given; an unexpected exception still shows its traceback.
"""

from __future__ import annotations

__all__ = ["LabError", "InputError", "LabRuntimeError", "EXIT_INPUT", "EXIT_RUNTIME", "EXIT_INTERRUPTED"]

#: Exit codes of the command line.
EXIT_INPUT = 2
EXIT_RUNTIME = 1
EXIT_INTERRUPTED = 130


class LabError(Exception):
    """Base of every error the package raises on purpose."""

    exit_code = EXIT_RUNTIME


class InputError(LabError, ValueError):
    """Bad input: a missing or malformed file, a bad field in it, or a bad argument."""

    exit_code = EXIT_INPUT


class LabRuntimeError(LabError, RuntimeError):
    """A runtime failure: the solver, the hardware or the motion capture failed."""

    exit_code = EXIT_RUNTIME
