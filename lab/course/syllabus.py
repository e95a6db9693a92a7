"""The course's syllabus: per chapter the paper's section, the goals, what it assumes, its exercises.

Chapter 00 shows the syllabus before anything runs: it is a Markdown cell of the notebook,
generated from this module and stored (so it reads on GitHub and in a fresh JupyterLab).
The fixed part (the paper's section a chapter reproduces, what a student can do after it,
what it assumes) is :data:`SYLLABUS`; the exercises are read from the chapters
themselves -- each "**Exercise N.M — title.**" heading and the function(s) of the
``solution`` cell that follows it -- so the list follows the chapters as they change.

:func:`syllabus_markdown` renders it; :func:`write_syllabus` stores it in chapter 00's
generated cell (``scripts/chapter-times --write`` and every ``scripts/reproduce`` run do;
``tests/test_student_path.py`` fails when the stored cell is stale). No run time is stated
here: those change from run to run and are in the chapter-times table (:mod:`lab.course.times`).
"""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path
from typing import NamedTuple

from lab.errors import InputError
from lab.files import atomic_write_text

__all__ = ["Chapter", "SYLLABUS", "exercises_of", "syllabus_markdown", "write_syllabus", "SYLLABUS_CELL"]

#: The generated cell of chapter 00 carries this in ``metadata["lab"]["generated"]``.
SYLLABUS_CELL = "syllabus"
#: An exercise heading in a chapter's Markdown: "**Exercise 1.2 — one Newton step.**"
EXERCISE = re.compile(r"\*\*Exercise (\d+\.\d+) [—-] ([^*]+?)\.?\*\*")


class Chapter(NamedTuple):
    name: str  # the notebook's file name
    paper: str  # the paper's section it reproduces, or the future-work section it takes up
    goals: str  # what a student can do afterwards
    assumes: str  # prerequisites


SYLLABUS = (
    Chapter("00_course.ipynb", "—", "find your way through the course", "—"),
    Chapter(
        "01_fem_simulation.ipynb",
        "IV (simulated data)",
        "describe a robot in TOML; build the neo-Hookean energy with one-sided cables; solve the statics with "
        "Newton; compute dx/du by sensitivity analysis; simulate the 308-command dataset",
        "Python, NumPy; a first course in mechanics",
    ),
    Chapter(
        "02_data_capture.ipynb",
        "III (capturing data)",
        "drive a rig; see why foam needs waiting (lag) and a reset (hysteresis); capture a dataset on the "
        "emulated as-built robot",
        "chapter 1",
    ),
    Chapter(
        "03_learned_model.ipynb",
        "II-C, V-A.3, Appendix",
        "write the network Jacobian of the Appendix; train with Levenberg-Marquardt as MATLAB's trainlm; run "
        "the ten-split accuracy study",
        "chapters 1-2; calculus (chain rule)",
    ),
    Chapter(
        "04_trajectory_following.ipynb",
        "II-A, II-B, II-D, V-A (Table I, Figures 3-4)",
        "solve IK by projected gradient descent and bounded LM; compare with Soft IK; follow trajectories open "
        "loop; reproduce Table I on the simulated and the emulated robot",
        "chapter 3; optimisation basics",
    ),
    Chapter(
        "05_sim_to_real.ipynb",
        "VI-B (future work: fine-tuning on few real samples)",
        "generate a family of as-built robots; trace the sim-to-real bias to its defects; fine-tune, fit a GP "
        "residual, choose few samples by a maximin design; read the error-vs-N curve",
        "chapters 2-4",
    ),
    Chapter(
        "06_six_cable_arm.ipynb",
        "V-B (Figure 5)",
        "scale data generation (joblib, Dask); train the 6-25-25-25-3 network; handle a redundant arm with "
        "regularised IK",
        "chapters 1-4",
    ),
    Chapter(
        "07_network_size.ipynb",
        "VI-A (Figure 6)",
        "study how network size trades expressiveness against data",
        "chapter 3",
    ),
    Chapter(
        "08_data_efficiency.ipynb",
        "VI-B (future work: efficient sampling)",
        "draw samples by space-filling designs and active learning; read data curves; compare the network with "
        "scikit-learn's GP, k-NN and MLP and a direct inverse; calibrate a deep ensemble's spread",
        "chapters 3, 6",
    ),
    Chapter(
        "09_dynamics_and_feedback.ipynb",
        "VI-B, VI-C (future work: viscous dynamics, dynamic motions)",
        "fit the foam's relaxation filter; capture 3-5x faster by predicting the settled tip (Kalman filter); "
        "correct trajectories with motion-capture feedback (ILC, per-target); stream trajectories at speed with "
        "a feed-forward through the filter's inverse",
        "chapters 2, 4",
    ),
    Chapter(
        "10_real_robot_data.ipynb",
        "II (the claim: measurements, no physics), tested on another lab's robot",
        "import another lab's measurements with their provenance; measure the repeatability floor, hysteresis "
        "and drift; compare models on random and group splits against the floor and the data's own baseline; "
        "add history; solve the IK for a robot without an FEM",
        "chapters 3, 4, 8",
    ),
    Chapter(
        "11_any_soft_body.ipynb",
        "beyond the paper: other labs' robots (tapered, CAD-meshed, tension-driven, markers on stalks)",
        "describe a body by its profile or a CAD file; drive tendons by angle and by tension and show they agree; "
        "put markers on stalks and solve the IK for one; calibrate stiffness and density of an emulated as-built "
        "tentacle from a few poses of every marker",
        "chapters 1, 4, 5",
    ),
    Chapter(
        "12_fluidic_arm.ipynb",
        "II-V on another actuator (pressure chambers), VI-B (few real samples)",
        "write a pressure chamber as an energy, the volume a closed surface encloses and its gradient; run the "
        "paper's pipeline (grid, network and its Jacobian, IK, tracking, Soft IK) on a Yeoh-silicone arm driven by "
        "pressures; measure where chambers and cables differ (workspace, softening and ballooning, nonlinearity, "
        "gravity); fine-tune on few samples of an emulated as-built pneumatic arm",
        "chapters 1, 3, 4, 5",
    ),
)


def _functions(source: str) -> list[str]:
    """The top-level functions of a solution cell as ``name(arguments)``."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return []
    out = []
    for n in (n for n in tree.body if isinstance(n, ast.FunctionDef)):
        a = n.args
        names = [x.arg for x in (*a.posonlyargs, *a.args)] + ([f"*{a.vararg.arg}"] if a.vararg else [])
        names += [x.arg for x in a.kwonlyargs] + ([f"**{a.kwarg.arg}"] if a.kwarg else [])
        out.append(f"{n.name}({', '.join(names)})")
    return out


def exercises_of(cells: list[dict]) -> list[tuple[str, str, list[str]]]:
    """A chapter's exercises in order: (number "N.M", title, the functions the student
    writes), from its "**Exercise N.M — title.**" Markdown and the ``solution`` cell after each."""
    found, waiting = [], []
    for cell in cells:
        text = "".join(cell["source"])
        if cell["cell_type"] == "markdown":
            for m in EXERCISE.finditer(text):
                found.append((m[1], " ".join(m[2].split()), []))
                waiting.append(found[-1])
        elif "solution" in cell.get("metadata", {}).get("tags", []) and waiting:
            waiting.pop(0)[2].extend(_functions(text))
    return found


def _cells(path: Path) -> list[dict]:
    try:
        return json.loads(path.read_text())["cells"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise InputError(f"{path}: not a notebook ({type(e).__name__}: {e})") from None


def _title(cells: list[dict], name: str) -> str:
    """The chapter's title: its first Markdown heading without the '#'s, else its file name."""
    for cell in cells:
        if cell["cell_type"] == "markdown":
            first = "".join(cell["source"]).strip().splitlines()[:1]
            if first and first[0].startswith("#"):
                return first[0].lstrip("#").strip()
    return name


def syllabus_markdown(notebooks: str | Path) -> str:
    """The syllabus as Markdown.

    Parameters
    ----------
    notebooks : str or pathlib.Path
        The folder of the chapters; chapters of :data:`SYLLABUS` absent from it are skipped.

    Returns
    -------
    str
        Per chapter after chapter 00: its title, linked, the paper's section, the
        prerequisites, the goals and the exercises (number, title, the functions to write).
    """
    notebooks, parts = Path(notebooks), []
    for ch in SYLLABUS[1:]:
        path = notebooks / ch.name
        if not path.exists():
            continue
        cells = _cells(path)
        lines = [
            f"### [{_title(cells, ch.name)}]({ch.name})",
            "",
            f"- **Paper:** {ch.paper} · **assumes:** {ch.assumes}",
            f"- **You learn to** {ch.goals}.",
        ]
        exercises = exercises_of(cells)
        if exercises:
            lines.append("- **Exercises:**")
            for number, title, functions in exercises:
                writes = " and ".join(f"`{f}`" for f in functions)
                lines.append(f"  - {number} {title}" + (f" — you write {writes}" if writes else ""))
        parts.append("\n".join(lines))
    return "\n\n".join(parts) + "\n"


def write_syllabus(chapter00: str | Path) -> bool:
    """Store :func:`syllabus_markdown` (of the notebooks beside ``chapter00``) in its cell
    whose ``metadata.lab.generated`` is :data:`SYLLABUS_CELL`; True when the text changed.
    :class:`~lab.errors.InputError` when the notebook has no such cell."""
    chapter00 = Path(chapter00)
    nb = json.loads(chapter00.read_text())
    cells = [c for c in nb["cells"] if c.get("metadata", {}).get("lab", {}).get("generated") == SYLLABUS_CELL]
    if len(cells) != 1:
        raise InputError(f"{chapter00}: needs one Markdown cell with metadata lab.generated = {SYLLABUS_CELL!r}")
    text = syllabus_markdown(chapter00.parent)
    if "".join(cells[0]["source"]) == text:
        return False
    cells[0]["source"] = text.splitlines(keepends=True)
    atomic_write_text(chapter00, json.dumps(nb, indent=1, ensure_ascii=False) + "\n")
    return True
