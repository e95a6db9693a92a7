"""What the graders of chapters 06 and 07 compare with (issue 13).

Exercise 7.2 checks the median and quartiles per width against ``lab.learn.summarize``,
whose ``q25`` / ``q75`` keys were added for it; the other keys must not change.
"""

import numpy as np
import pytest

from lab.learn import summarize


def test_summarize_gives_quartiles_next_to_the_old_keys():
    rows = [{"width": w, "d": d} for w, d in [(8, 4.0), (2, 1.0), (8, 1.0), (2, np.nan), (8, 2.0), (8, 3.0), (2, 3.0)]]
    w8, w2 = summarize(rows, "width", "d")  # order of first appearance
    assert w8["width"] == 8 and w2["width"] == 2
    assert w8["n"] == 4 and (w8["q25"], w8["median"], w8["q75"]) == pytest.approx((1.75, 2.5, 3.25))
    assert w8["mean"] == 2.5 and w8["std"] == pytest.approx(np.std([1, 2, 3, 4], ddof=1))
    assert (w8["min"], w8["max"]) == (1.0, 4.0)
    assert w2["n"] == 2 and (w2["q25"], w2["median"], w2["q75"]) == pytest.approx((1.5, 2.0, 2.5))  # NaN dropped


def test_summarize_quartiles_of_one_run_and_of_none():
    one, none = summarize([{"k": 1, "v": 7.0}, {"k": 2, "v": np.nan}], "k", "v")
    assert one["q25"] == one["median"] == one["q75"] == 7.0 and np.isnan(one["std"])
    assert none["n"] == 0 and np.isnan(none["q25"]) and np.isnan(none["q75"])
