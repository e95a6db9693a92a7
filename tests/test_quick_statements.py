"""A chapter's text holds in quick mode as in full mode.

A number with a unit in a chapter's Markdown ("0.45 cm", "12 s", "5 %") is either a fact
true in both modes (a dimension, a parameter, the paper's value) and then listed in the
notebook's metadata ``lab.numbers_true_in_both_modes``, or it is measured by the run, and
then the sentence is not Markdown but a computed statement (``lab.course.say``) formatted
from the run's values. ``tests/test_notebooks.py`` runs every chapter quick and checks that
each computed statement rendered.
"""

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
#: a number (or a range of two) followed by a unit
NUMBER = re.compile(
    r"(?<![\w.])\d[\d,]*(?:\.\d+)?(?:\s*[–-]\s*\d+(?:\.\d+)?)?(?:\s*%|\s+(?:cm|mm|µm|s|min|h|rad|ms|samples/h)(?![\w]))"
)


def markdown_numbers(cells) -> list[str]:
    """Every number with a unit in the Markdown cells, in order (repeats included)."""
    return [m.group(0) for c in cells if c["cell_type"] == "markdown" for m in NUMBER.finditer("".join(c["source"]))]


def test_the_scanner_sees_numbers_with_units():
    cells = [{"cell_type": "markdown", "source": ["tracks at 0.45 cm (paper: 0.04–0.06 cm) in 12 s; 2h and v2.5 not"]}]
    assert markdown_numbers(cells) == ["0.45 cm", "0.04–0.06 cm", "12 s"]


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[nb.name for nb in NOTEBOOKS])
def test_markdown_states_only_numbers_true_in_both_modes(notebook):
    nb = json.loads(notebook.read_text())
    fixed = set(nb["metadata"].get("lab", {}).get("numbers_true_in_both_modes", []))
    unknown = sorted(set(markdown_numbers(nb["cells"])) - fixed)
    assert not unknown, (
        f"{notebook.name}: Markdown states {unknown}: compute each from the run (lab.course.say) or, if it is true "
        "in quick and full mode alike, list it in the notebook metadata lab.numbers_true_in_both_modes"
    )
    stale = sorted(fixed - set(markdown_numbers(nb["cells"])))
    assert not stale, f"{notebook.name}: lab.numbers_true_in_both_modes lists {stale}, which no Markdown cell states"
