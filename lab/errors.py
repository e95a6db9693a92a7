"""One root exception for everything the package raises on purpose, and what it means.

Every error ``lab`` raises deliberately derives from :class:`LabError`. Its
``exit_code`` is what the command line returns for it:

* :class:`InputError` -- bad input: a file, a field in it, or an argument (exit code 2).
  It is also a ``ValueError``, so ``except ValueError`` keeps working; a bad setting of a
  spec (:mod:`lab.specs`) raises :class:`FieldError`, which names it ``Class.field``;
* :class:`LabRuntimeError` -- the work itself failed: a solver that did not converge, a
  servo or motion-capture failure (exit code 1). It is also a ``RuntimeError``.

``python -m lab`` prints ``error: <message>`` for either, without a traceback unless
``--debug`` is given (a :class:`FieldError`'s fields named as the flags the user typed);
an unexpected exception still shows its traceback.
"""

from __future__ import annotations

import re

__all__ = ["LabError", "InputError", "FieldError", "LabRuntimeError", "EXIT_INPUT", "EXIT_RUNTIME", "EXIT_INTERRUPTED"]

#: Exit codes of the command line.
EXIT_INPUT = 2
EXIT_RUNTIME = 1
EXIT_INTERRUPTED = 130
#: A setting in a message: ``Class.field``.
_NAME = re.compile(r"(?<![\w.])[A-Z]\w*\.[a-z_]\w*")


class LabError(Exception):
    """Base of every error the package raises on purpose."""

    exit_code = EXIT_RUNTIME


class InputError(LabError, ValueError):
    """Bad input: a missing or malformed file, a bad field in it, or a bad argument."""

    exit_code = EXIT_INPUT


class LabRuntimeError(LabError, RuntimeError):
    """A runtime failure: the solver, the hardware or the motion capture failed."""

    exit_code = EXIT_RUNTIME


class FieldError(InputError):
    """A bad value of one or more settings of a spec, each named ``Class.field`` in the message.

    Parameters
    ----------
    message : str
        What is wrong, naming each setting as ``Class.field`` (e.g. ``"TrackSpec.period_s must
        be finite and > 0, got -1"``); the command line writes its flag in their place.
    *names : str
        The settings the message names, each ``"Class.field"``; the first is :attr:`spec`
        and :attr:`field`. A cross-field rule names all the fields it relates. Default: every
        ``Class.field`` the message holds.

    Attributes
    ----------
    spec : str
        The class name of the first setting (e.g. ``"TrackSpec"``).
    field : str
        The field name of the first setting (e.g. ``"period_s"``).
    fields : tuple of str
        The field names of all settings, in order.
    names : tuple of str
        The settings as ``"Class.field"``.
    """

    def __init__(self, message: str, *names: str):
        super().__init__(message)
        self.names = tuple(names) or tuple(dict.fromkeys(_NAME.findall(message)))
        self.spec, _, self.field = self.names[0].partition(".") if self.names else ("", "", "")
        self.fields = tuple(n.partition(".")[2] for n in self.names)

    #: Whether the error is about one setting's own value (its check or choices), not a rule.
    value_check = False

    def of_value(self) -> FieldError:
        """This error, marked as about one setting's own value (:attr:`value_check`).

        Returns
        -------
        FieldError
            ``self``.
        """
        self.value_check = True
        return self

    def renamed(self, name_of) -> str:
        """The message with each setting written as ``name_of("Class.field")`` instead.

        Parameters
        ----------
        name_of : callable
            ``name_of(name) -> str``: how to write the setting ``name`` (e.g. as a flag).

        Returns
        -------
        str
            The message with every ``Class.field`` of :attr:`names` replaced.
        """
        text = str(self)
        for name in sorted(set(self.names), key=len, reverse=True):
            text = re.sub(rf"(?<![\w.]){re.escape(name)}(?!\w)", lambda _m, n=name: name_of(n), text)
        return text
