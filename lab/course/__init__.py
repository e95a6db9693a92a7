"""The course's exercises: graders, computed statements, and the student edition.

- :mod:`lab.course.grading`: :func:`grade` checks a student's function against ``lab``'s
  own implementation on random inputs and shows one result (HTML in JupyterLab, plain text
  elsewhere);
- :mod:`lab.course.statements`: :func:`say` shows a sentence formatted from the run's own
  values, so a chapter's text holds in quick and in full mode;
- :mod:`lab.course.edition`: :func:`student_edition`, the chapter with the solutions removed.
"""

from lab.course.edition import GRADER_TAG, SOLUTION_TAG, stub_source, student_edition
from lab.course.grading import NOT_IMPLEMENTED, Grade, grade
from lab.course.statements import say, than

__all__ = [
    "grade",
    "Grade",
    "say",
    "than",
    "student_edition",
    "stub_source",
    "SOLUTION_TAG",
    "GRADER_TAG",
    "NOT_IMPLEMENTED",
]
