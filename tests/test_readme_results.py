"""The README's sim-to-real numbers are the cached studies' numbers (not typed in by hand)."""

import re
from pathlib import Path

import numpy as np
import pytest

from lab.studies.transfer_study import read_curve

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.timeout(60)


def _section() -> str:
    text = (ROOT / "README.md").read_text()
    start = text.index("### Few real samples on top of the simulation")
    return text[start : text.index("\n### ", start + 10)]


def _mean_cm(rows, method, n) -> float:
    return 100 * float(np.mean([r["tracking_mean_m"] for r in rows if r["method"] == method and r["n_real"] == n]))


@pytest.mark.parametrize(
    ("family", "curve", "quoted"),
    [
        (
            "In our FEM's model class",
            "transfer_curve.csv",
            [("calibrated", 10), ("calibrated", 5), ("finetune", 30), ("real-only", 308)],
        ),
        (
            "Outside it",
            "transfer_curve_foam.csv",
            [("finetune", 30), ("real-only", 308), ("calibrated", 5), ("calibrated", 10), ("calibrated", 30)],
        ),
    ],
)
def test_readme_quotes_the_family_means_of_the_cached_curves(family, curve, quoted):
    section = _section()
    bullet = section[section.index(family) :].split("\n- ")[0]
    rows = [r for r in read_curve(ROOT / "data" / curve) if r["robot"] != "shipped"]
    numbers = re.findall(r"\d+\.\d{3}", bullet)
    assert numbers == [f"{_mean_cm(rows, m, n):.3f}" for m, n in quoted]
