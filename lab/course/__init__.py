"""The course's exercises: graders, computed statements, and the student edition.

- :mod:`lab.course.grading`: :func:`grade` checks a student's function against ``lab``'s
  own implementation on random inputs and shows one result (HTML in JupyterLab, plain text
  elsewhere);
- :mod:`lab.course.statements`: :func:`say` shows a sentence formatted from the run's own
  values, so a chapter's text holds in quick and in full mode;
- :mod:`lab.course.edition`: :func:`~lab.course.edition.student_edition`, the chapter with the solutions removed;
  :func:`build_student_edition`, the whole course in ``build/student/``, keeping the student's work;
- :mod:`lab.course.syllabus`, :mod:`lab.course.times`: chapter 00's syllabus and the measured
  time per chapter (``python -m lab.course``, :mod:`lab.course.commands`, for the scripts).

The names below are loaded from their modules on first use, so that ``python -m lab.course``
starts without importing NumPy before it can answer a Ctrl-C (``lab.course.__main__``).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lab.course.edition import GRADER_TAG, SOLUTION_TAG, build_student_edition
    from lab.course.grading import NOT_IMPLEMENTED, Grade, grade
    from lab.course.statements import say, than
    from lab.course.stubs import stub_source
    from lab.course.syllabus import syllabus_markdown
    from lab.course.times import times_markdown

__all__ = [
    "grade",
    "Grade",
    "say",
    "than",
    "build_student_edition",
    "syllabus_markdown",
    "times_markdown",
    "stub_source",
    "SOLUTION_TAG",
    "GRADER_TAG",
    "NOT_IMPLEMENTED",
]

#: Where each public name is defined.
_HOME = {
    "grade": "grading",
    "Grade": "grading",
    "NOT_IMPLEMENTED": "grading",
    "say": "statements",
    "than": "statements",
    "build_student_edition": "edition",
    "stub_source": "stubs",
    "SOLUTION_TAG": "edition",
    "GRADER_TAG": "edition",
    "syllabus_markdown": "syllabus",
    "times_markdown": "times",
}


def __getattr__(name: str):
    if name not in _HOME:
        raise AttributeError(f"module 'lab.course' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"lab.course.{_HOME[name]}"), name)
    globals()[name] = value  # loaded once
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
