"""Execute every notebooks/NN_*.ipynb end to end with papermill.

Each notebook runs with ``quick=True`` (its reduced-size mode) and a temporary
``figures_dir``, in a kernel of the interpreter running pytest, with
notebooks/ as its working directory. A cell error fails the test. A notebook
that declares a ``figures_dir`` parameter must write at least one file there.

One test per notebook, found when the module is collected; no notebooks, no
tests.
"""

import re
import sys
from pathlib import Path

import pytest
from helpers import NOTEBOOK_TEST_TIMEOUT_S, execute_notebook, output_text

NOTEBOOKS_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOKS_DIR.glob("[0-9][0-9]_*.ipynb"))
KERNEL_NAME = "lab-test-python"


@pytest.fixture
def this_interpreter_kernel(tmp_path_factory, monkeypatch):
    """A kernel spec that starts ``sys.executable``, found before any other.

    Without it, the kernel name comes from the notebook's metadata and could
    resolve to a kernel spec of some other Python on the machine.
    """
    from ipykernel.kernelspec import write_kernel_spec

    jupyter_path = tmp_path_factory.mktemp("jupyter")
    write_kernel_spec(
        jupyter_path / "kernels" / KERNEL_NAME,
        overrides={"display_name": f"pytest {sys.executable}"},
    )
    monkeypatch.setenv("JUPYTER_PATH", str(jupyter_path))
    return KERNEL_NAME


if NOTEBOOKS:

    @pytest.mark.slow
    @pytest.mark.timeout(NOTEBOOK_TEST_TIMEOUT_S)
    @pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[nb.name for nb in NOTEBOOKS])
    def test_notebook_runs(notebook, tmp_path, this_interpreter_kernel):
        import papermill

        figures_dir = tmp_path / "figures"
        execute_notebook(
            notebook,
            tmp_path / notebook.name,
            parameters={"quick": True, "figures_dir": str(figures_dir)},
            cwd=str(NOTEBOOKS_DIR),
            kernel_name=this_interpreter_kernel,
        )

        # Every exercise's reference solution passes its grader (lab.course.grade).
        import json

        for cell in json.loads((tmp_path / notebook.name).read_text())["cells"]:
            if "grader" in cell.get("metadata", {}).get("tags", []):
                text = output_text(cell)
                assert "passed" in text, f"{notebook.name}: a reference solution fails its grader: {text}"

        # Every computed statement (lab.course.say) rendered a sentence from the run's values.
        from lab.course.statements import STATEMENT_KEY

        for cell in json.loads((tmp_path / notebook.name).read_text())["cells"]:
            for o in cell.get("outputs", []):
                if o.get("metadata", {}).get(STATEMENT_KEY):
                    text = "".join(o["data"]["text/plain"])
                    assert text.strip() and not re.search(r"[{}]|\bnan\b", text), f"{notebook.name}: statement {text!r}"

        if "figures_dir" in papermill.inspect_notebook(str(notebook)):
            written = [p for p in figures_dir.rglob("*") if p.is_file()]
            assert written, f"{notebook.name} declares figures_dir but wrote no file into it"
