"""What a failing grader says: where the result differs, in words; the failing case as code
to paste; the call that runs that case alone (``case=``), which fails the same way.

The chapter tests (tests/test_course_ch*.py) check with ``helpers.assert_reruns`` that a
wrong answer to each checker fails with a rerun line and that the rerun repeats the failure
word for word; here are the wording, the size limit, the bad ``case=`` and one light checker
(chapter 5's GP Jacobian) in detail.
"""

import ast
from pathlib import Path

import numpy as np
import pytest

from lab.course import NOT_IMPLEMENTED, grade
from lab.course.ch02 import check_goal_ticks
from lab.course.ch05 import check_gp_jacobian
from lab.course.failures import SHOWN_NUMBERS, as_code, describe_inputs, where_differs
from lab.errors import InputError

ROOT = Path(__file__).resolve().parent.parent


# ---- where it differs -------------------------------------------------------------------


def test_where_a_result_differs_is_said_as_a_reader_counts():
    assert where_differs(5.0, 4.0, 0.0, 0.0) == "the result is 5, expected 4 (off by 1, allowed 0)"
    assert where_differs(np.array([1.0, 2.0, 7.0]), np.arange(1.0, 4.0), 0.0, 1e-9).startswith(
        "entry 3 of the result (result[2]) is 7, expected 3 (off by 4, allowed 1e-09)"
    )
    got, want = np.array([[1.0, 2.0], [3.0, 5.0]]), np.array([[1.0, 2.0], [3.0, 4.0]])
    assert where_differs(got, want, 0.0, 0.5) == (
        "row 2, column 2 of the result (result[1, 1]) is 5, expected 4 (off by 1, allowed 0.5)"
    )
    # the first entry in reading order, and how many more differ
    said = where_differs((1.0, 2.0, np.array([0.0, 9.0, 9.0, 3.0])), (1.0, 2.0, np.arange(4.0)), 0.0, 0.0)
    assert said == "entry 2 of the 3rd returned value (result[2][1]) is 9, expected 1 (off by 8, allowed 0); " + (
        "1 more of its 4 entries differ"
    )
    # enough digits to tell the two apart, and the excess over the tolerance as well
    assert (
        where_differs(1.0000001, 1.0, 0.0, 1e-9) == "the result is 1.0000001, expected 1 (off by 1e-07, allowed 1e-09)"
    )
    assert "(off by 1.021e-06, allowed 1e-06)" in where_differs(1.000001021, 1.0, 0.0, 1e-6)
    assert where_differs(np.nan, 4.0, 0.0, 1.0) == "the result is nan, expected 4"
    assert where_differs((1.0, np.ones(2)), (1.0, np.ones(2)), 0.0, 0.0) is None


def test_a_wrong_shape_type_or_count_is_said_so():
    assert where_differs((0.0, np.zeros(2)), (0.0, np.zeros(3)), 0, 0) == (
        "the 2nd returned value (result[1]) is an array of shape (2,), expected an array of shape (3,)"
    )
    assert where_differs(np.zeros(3), 1.0, 0, 0) == "the result is an array of shape (3,), expected a single number"
    assert where_differs("a", 1.0, 0, 0) == "the result is a str, expected numbers"
    assert where_differs(np.zeros(2), (1.0, 2.0), 0, 0) == "the result is one ndarray, expected a tuple of 2 values"
    assert where_differs((1.0,), (1.0, 2.0), 0, 0) == "the result is a tuple of 1, expected a tuple of 2 values"
    assert where_differs((1.0, (2.0, 3.0)), (1.0, (2.0, 4.0)), 0, 0).startswith(
        "item 2 of the 2nd returned value (result[1][1]) is 3, expected 4"
    )


def test_the_pass_and_todo_messages_are_unchanged():
    ref = lambda x: 2 * x  # noqa: E731
    assert grade("demo", ref, ref, [(1.0,), (2.0,)], show=False) == "exercise 'demo': passed (2 random cases)"

    def todo(x):
        raise NotImplementedError

    said = grade("demo", todo, ref, [(1.0,)], show=False)
    assert said == f"exercise 'demo': {NOT_IMPLEMENTED} - write the function above, then run this cell again"
    assert (said.status, said.details, said.case, said.inputs) == ("todo", "", None, None)


# ---- the inputs as code -----------------------------------------------------------------

RNG = np.random.default_rng(0)
VALUES = [
    17,
    -2.5,
    0.1 + 0.2,
    None,
    "a name",
    True,
    np.arange(6).reshape(2, 3),
    np.linspace(0.0, 1.0, 7) ** 3,
    np.array([np.nan, np.inf, -np.inf, 1e-300, -0.0]),
    np.zeros((0, 3)),
    np.arange(4, dtype=np.int32),
    np.array([True, False]),
    np.array(2.5),
    (1.5, 2),
    (3.0,),
    [np.arange(3.0), 4],
    RNG.normal(size=(3, 4, 2)),
    RNG.normal(size=SHOWN_NUMBERS),
]


@pytest.mark.parametrize("value", VALUES, ids=range(len(VALUES)))
def test_an_input_prints_as_code_that_rebuilds_it(value):
    code = as_code(value)
    back = eval(code, {"np": np})
    assert type(back) is type(value), code
    if isinstance(value, np.ndarray):
        assert back.dtype == value.dtype and back.shape == value.shape, code
        np.testing.assert_array_equal(back, value)  # every digit: NaN where NaN, -0.0 as -0.0
        assert np.array_equal(np.signbit(back), np.signbit(value)), code
    elif isinstance(value, list):
        assert all(np.array_equal(b, v) for b, v in zip(back, value)), code
    else:
        assert back == value, code


def test_a_long_array_is_printed_a_row_per_line():
    code = as_code(RNG.normal(size=(5, 3)))
    assert code.startswith("np.array([\n    [") and code.endswith("],\n])") and code.count("\n") == 6, code
    assert max(len(line) for line in as_code(RNG.normal(size=SHOWN_NUMBERS)).splitlines()) <= 88


def test_an_input_over_the_limit_or_an_object_is_not_printed():
    assert as_code(np.zeros(SHOWN_NUMBERS)).startswith("np.array([")
    big = 1000.0 + np.arange(SHOWN_NUMBERS + 1)
    assert as_code(big) == f"...  # an array of shape ({SHOWN_NUMBERS + 1},): {SHOWN_NUMBERS + 1} numbers, not printed"
    assert as_code([np.zeros(40), np.zeros(40)]) == "...  # a list of 2 items, 80 numbers, not printed"
    assert as_code(object()) == "...  # an object of type object, not printed"
    assert describe_inputs((1, 2.5), ["n"]) == "n = 1\narg2 = 2.5"

    result = grade("demo", lambda x, n: x[:n].sum() + 1, lambda x, n: x[:n].sum(), [(big, 3)], show=False)
    assert "x = ...  # an array of shape (61,): 61 numbers, not printed\nn = 3" in result.details, result.details
    assert "1060.0" not in result.details and "1000.0" not in result.details  # its numbers are not dumped
    assert "the result's .inputs holds them all" in result.details
    assert result.inputs[0] is not big and np.array_equal(result.inputs[0], big) and result.inputs[1] == 3


def test_the_inputs_shown_are_those_given_even_if_the_function_changes_them():
    def doubles_in_place(x):
        x *= 2
        return x

    result = grade("demo", doubles_in_place, lambda x: np.ones(2), [(np.ones(2),)], show=False)
    assert "x = np.array([1.0, 1.0])" in result.details and np.array_equal(result.inputs[0], np.ones(2))


# ---- a checker's rerun -------------------------------------------------------------------


def gp_jacobian(X, alpha, length_scales, s2, u):
    """Right for up to 5 samples, 1.5 times too large beyond: chapter 5's case 2 has 7."""
    k = s2 * np.exp(-0.5 * np.sum(((u - X) / length_scales) ** 2, axis=1))
    J = np.einsum("nk,nj->kj", alpha, -k[:, None] * (u - X) / length_scales**2)
    return J * (1.5 if len(X) > 5 else 1.0)


def test_a_failure_names_the_call_that_reruns_its_case_and_the_case_as_code():
    result = check_gp_jacobian(gp_jacobian, show=False)
    assert result.status == "failed" and result.case == 2, result
    assert str(result).startswith(
        "exercise 'GP residual Jacobian': FAILED on case 2 of 4: row 1, column 1 of the result (result[0, 0]) is "
    ), result
    lines = result.details.splitlines()
    assert lines[:2] == ["To rerun it: check_gp_jacobian(gp_jacobian, case=2)", "Its inputs, as code to paste:"]
    assert lines[-1] == "gp_jacobian(X, alpha, length_scales, s2, u)"
    scope = {"np": np}
    exec("\n".join(lines[2:-1]), scope)  # pasted: the very inputs of case 2
    for name, value in zip(("X", "alpha", "length_scales", "s2", "u"), result.inputs, strict=True):
        np.testing.assert_array_equal(scope[name], value)
    assert np.array_equal(eval(lines[-1], {**scope, "gp_jacobian": gp_jacobian}), gp_jacobian(*result.inputs))

    again = check_gp_jacobian(gp_jacobian, case=2, show=False)
    assert (again.status, again.case, str(again), again.details) == ("failed", 2, str(result), result.details)
    passed = check_gp_jacobian(gp_jacobian, case=1, show=False)
    assert (passed.status, passed) == ("passed", "exercise 'GP residual Jacobian': case 1 of 4 passed")
    assert check_gp_jacobian(gp_jacobian, case=np.int64(3), show=False).case == 3


def test_an_error_in_the_function_is_rerun_the_same_way():
    def raises_beyond_five(X, alpha, length_scales, s2, u):
        if len(X) > 5:
            raise ZeroDivisionError("division by zero")
        return gp_jacobian(X, alpha, length_scales, s2, u)

    result = check_gp_jacobian(raises_beyond_five, show=False)
    assert str(result).endswith("FAILED on case 2 of 4: ZeroDivisionError: division by zero"), result
    assert result.details.startswith("To rerun it: check_gp_jacobian(raises_beyond_five, case=2)\n")
    again = check_gp_jacobian(raises_beyond_five, case=2, show=False)
    assert (str(again), again.details) == (str(result), result.details)


def test_the_rerun_line_is_the_call_as_written_else_the_checker_and_its_parameters():
    ticks = lambda u, z, d: np.asarray(z)  # noqa: E731 - wrong: the angle is left out
    result = check_goal_ticks(ticks, 3.0, show=False)
    assert result.details.splitlines()[0] == "To rerun it: check_goal_ticks(ticks, 3.0, case=1)"
    assert result.details.splitlines()[-1] == "ticks(u, z, d)"  # the name the call gives it
    written = check_goal_ticks(
        lambda u, z, d: np.asarray(z),
        3.0,
        show=False,
    )
    assert (
        written.details.splitlines()[0] == "To rerun it: check_goal_ticks(lambda u, z, d: np.asarray(z), 3.0, case=1)"
    )
    assert written.details.splitlines()[-1] == "your_function(u, z, d)"
    after_accents = ("déjà", check_goal_ticks(ticks, 3.0, show=False))[1]  # columns count bytes, not letters
    assert after_accents.details == result.details
    check = check_goal_ticks  # a call that does not name the checker: its name and parameters instead
    unnamed = check(ticks, 3.0, show=False)
    assert unnamed.details.splitlines()[0] == "To rerun it: check_goal_ticks(your_function, u_max_rad, case=1)"
    assert str(unnamed) == str(result)


@pytest.mark.parametrize("case", [0, 5, -1, 2.0, "2", True])
def test_a_case_that_names_no_case_raises_naming_the_range(case):
    with pytest.raises(InputError, match=r"case must be a whole number from 1 to 4 \(check_gp_jacobian has 4 cases\)"):
        check_gp_jacobian(gp_jacobian, case=case, show=False)
    assert issubclass(InputError, ValueError)


def test_every_checker_takes_case_and_names_itself_to_grade():
    """Each ``check_*`` of lab/course/chNN.py has the keyword ``case`` and passes it, and
    itself as ``checker``, to its one ``grade`` call (a new checker without them fails here)."""
    checkers = 0
    for path in sorted((ROOT / "lab" / "course").glob("ch[0-9][0-9].py")):
        tree = ast.parse(path.read_text())
        found = [f for f in tree.body if isinstance(f, ast.FunctionDef) and f.name.startswith("check_")]
        assert found, f"{path.name} has no checker"
        for fn in found:
            assert "case" in [a.arg for a in fn.args.kwonlyargs], f"{path.name}: {fn.name} takes no case="
            calls = [c for c in ast.walk(fn) if isinstance(c, ast.Call) and getattr(c.func, "id", "") == "grade"]
            assert len(calls) == 1, f"{path.name}: {fn.name}"
            passed = {k.arg: getattr(k.value, "id", None) for k in calls[0].keywords}
            assert passed.get("case") == "case" and passed.get("checker") == fn.name, f"{path.name}: {fn.name}"
            checkers += 1
    assert checkers >= 12
