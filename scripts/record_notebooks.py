"""Store compact recorded copies of executed chapters for the documentation site.

    python scripts/record_notebooks.py --figures figures --out figures/notebooks build/notebooks/NN_*.ipynb

scripts/reproduce calls this after a full run: it turns each executed chapter papermill wrote
to build/notebooks/ into ``figures/notebooks/NN_name.ipynb``, committed like the rest of
figures/, so that the site (scripts/docs) shows every chapter with the outputs of a recorded
run from a fresh clone -- the notebooks in notebooks/ stay cleared. The site renders each
output by its richest representation it can show without a kernel (an image before text), so
a recorded copy keeps every figure the text refers to and stays small:

* a figure a cell saved into figures/ is shown as a reference to that committed file (the
  inline image of it the kernel drew is dropped); any other inline image (a plot a cell only
  shows with ``plt.show()``) stays, embedded;
* a widget (sliders) needs a kernel: its view is dropped. What the widget carries beside it
  stays -- the course's sliders carry the image they drew (:class:`lab.viz.ArmExplorer`) --
  with a line saying the sliders need a running chapter; a widget with nothing but its text
  (``VBox(children=...)``) is replaced by that line;
* a representation over ``MAX_OUTPUT_BYTES`` (a self-contained 3-D scene: meshcat's JavaScript
  is about a megabyte) is dropped. If the output has a smaller image beside it (the still of
  :class:`lab.viz.SceneView`), that image is shown, with a line saying what was left out;
  otherwise a line stands in for the whole output. A plot's PNG over the limit is first
  re-encoded smaller (:func:`fitted_png`), so that no plot is lost to the rule.

The exercises' solution cells show the reference solutions that ran (the graders' "passed"
is theirs), folded on the site (MyST-NB's ``hide-input``) so that a reader working through
the exercises does not see them unasked. Per-cell timestamps are dropped (no churn in git).

Cell ids are stable: a cell keeps the id it has in the source chapter (``--source``, default
notebooks/), and a cell the source has not -- papermill's injected parameters, which nbformat
gives a new random id on every run -- keeps the id of the same cell in the recorded copy it
replaces (else ``injected-parameters``). A recorded copy that differs from the stored one only
in the date of its note is not rewritten: a re-run with the same outputs changes no file.
"""

from __future__ import annotations

import argparse
import base64
import io
import json
import os
import re
import sys
from pathlib import Path

from lab.course.edition import SOLUTION_TAG
from lab.errors import InputError
from lab.files import atomic_write_text

#: Representations larger than this (bytes, as stored: base64 for an image) are left out.
MAX_OUTPUT_BYTES = 200_000
#: Mime types that need a live kernel: dropped, the output's other representations stay.
KERNEL_ONLY = ("application/vnd.jupyter.widget-view+json",)
#: A figure file named in a cell's source or printed by it ("wrote ../figures/x.png").
FIGURE_NAME = re.compile(r"[\w.-]+\.(?:png|html)\b")
#: The line under (or instead of) a widget: it needs a kernel.
WIDGET_NOTE = "*(an interactive widget: run the chapter in JupyterLab to use it{shown})*"
#: Cell metadata of an exercise's reference solution: folded on the site, with MyST-NB's prompts.
SOLUTION_FOLD = {
    "tags": ["hide-input"],
    "mystnb": {"code_prompt_show": "Show the reference solution", "code_prompt_hide": "Hide the reference solution"},
}


def _text(value) -> str:
    return "".join(value) if isinstance(value, list) else value if isinstance(value, str) else json.dumps(value)


def saved_figures(cell: dict, figures_dir: Path) -> list[str]:
    """The files of ``figures_dir`` a code cell saved, in the order it names them: names in
    its source (cells that save into ``figures_dir``) and in the paths it printed."""
    source = _text(cell["source"])
    texts = [_text(o.get("text", "")) for o in cell.get("outputs", []) if o.get("output_type") == "stream"]
    names = FIGURE_NAME.findall(source) if ("figures_dir" in source or "savefig" in source) else []
    names += [os.path.basename(n) for t in texts for n in FIGURE_NAME.findall(t)]
    return [n for n in dict.fromkeys(names) if (figures_dir / n).is_file()]


def _reference(name: str, figures_dir: Path, out_dir: Path) -> dict:
    rel = Path(os.path.relpath(figures_dir / name, out_dir)).as_posix()
    # (a page of its own, e.g. an animation, is named, not copied into the site: megabytes)
    text = f"![{name}]({rel})" if name.endswith(".png") else f"`{name}`: a page of its own in `figures/`, for a browser"
    return {"output_type": "display_data", "metadata": {}, "data": {"text/markdown": text, "text/plain": name}}


def _note(text: str) -> dict:
    return {"output_type": "display_data", "metadata": {}, "data": {"text/markdown": text, "text/plain": text}}


def _size(value) -> int:
    return len(_text(value).encode())


def fitted_png(b64: str) -> str | None:
    """The PNG ``b64`` (base64) re-encoded to fit :data:`MAX_OUTPUT_BYTES`: as a 256-colour
    palette image, then halved in size until it fits; None if it never does, or if it is no
    still PNG (an animated one is made to fit where it is drawn: lab.viz.stills)."""
    from PIL import Image

    try:
        image = Image.open(io.BytesIO(base64.b64decode(b64)))
        image.load()
    except (OSError, ValueError):
        return None
    if getattr(image, "is_animated", False):
        return None
    image = image.convert("RGB")
    while min(image.size) >= 100:
        buf = io.BytesIO()
        image.quantize(colors=256, dither=Image.Dither.NONE).save(buf, format="PNG", optimize=True)
        fitted = base64.b64encode(buf.getvalue()).decode("ascii")
        if len(fitted) <= MAX_OUTPUT_BYTES:
            return fitted
        image = image.resize((image.width // 2, image.height // 2), Image.Resampling.LANCZOS)
    return None


def compact_outputs(outputs: list[dict], n_figures: int) -> list[dict]:
    """The outputs for a recorded copy: without the first ``n_figures`` inline images (they
    duplicate the figures the cell saved), without kernel-only mime types, and without any
    representation over :data:`MAX_OUTPUT_BYTES` (a PNG over it is first made to fit:
    :func:`fitted_png`); a widget or an output that lost its large representation keeps what
    it has beside (an image) with a line saying what is left out, or becomes that line if it
    has nothing but text."""
    kept = []
    for out in outputs:
        data = out.get("data")
        if data is None:
            kept.append(out)
            continue
        if n_figures and any(k.startswith("image/") for k in data):
            n_figures -= 1
            continue
        widget = any(k in data for k in KERNEL_ONLY)
        if _size(data.get("image/png", "")) > MAX_OUTPUT_BYTES and (fitted := fitted_png(_text(data["image/png"]))):
            data = {**data, "image/png": fitted}  # a large plot, made smaller: it stays
        large = {k: _size(v) for k, v in data.items() if k not in KERNEL_ONLY and _size(v) > MAX_OUTPUT_BYTES}
        data = {k: v for k, v in data.items() if k not in KERNEL_ONLY and k not in large}
        shown = any(k != "text/plain" for k in data)
        if large:
            what = f"{max(large.values()) / 1e6:.1f} MB ({', '.join(sorted(large))})"
            if any(k.startswith("image/") for k in data):
                line = f"*(above: a still image of an output of {what} that is left out of the recorded copy; "
                line += "run the chapter for the interactive view)*"
            else:
                line = f"*(an output of {what} is left out of the recorded copy: run the chapter to see it)*"
        elif widget:
            line = WIDGET_NOTE.format(shown="; above, the image it drew when the chapter ran" if shown else "")
        else:
            line = None
        if shown or line is None:
            kept.append({**out, "data": data, "metadata": out.get("metadata", {})})
        if line is not None:
            kept.append(_note(line))
    return kept


def _without_root(out: dict) -> dict:
    """``out`` with this checkout's absolute path written as ``<repository>``: the recorded
    copy shows where a file is in the repository, not on the machine that ran it."""
    root = str(Path(__file__).resolve().parent.parent)

    def strip(v):
        return [t.replace(root, "<repository>") for t in v] if isinstance(v, list) else v.replace(root, "<repository>")

    out = dict(out)
    if "text" in out:
        out["text"] = strip(out["text"])
    if "data" in out:
        out["data"] = {k: strip(v) if k.startswith("text/") else v for k, v in out["data"].items()}
    return out


def _notebook(path: Path, what: str) -> dict:
    """The notebook at ``path`` as a dict with a list of cells; an InputError naming it if not."""
    try:
        nb = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise InputError(f"{path}: not {what} ({type(e).__name__}: {e})") from None
    if not isinstance(nb, dict) or not isinstance(nb.get("cells", []), list):
        raise InputError(f"{path}: not {what} (no list of cells)")
    nb.setdefault("cells", [])
    return nb


def stable_ids(cells: list[dict], source: list[dict] | None, stored: list[dict]) -> None:
    """Give ``cells`` (an executed chapter's) the ids of the source chapter's cells (``source``;
    None: every cell but papermill's injected parameters keeps its id) and, where the source has
    no such cell, of the stored recorded copy (``stored``): matched by their tags and their place
    among such cells; the injected parameters fall back to ``injected-parameters``. Cells are
    changed in place; ids stay unique."""
    if source is None:
        source = [c for c in cells if "injected-parameters" not in c.get("metadata", {}).get("tags", [])]
    known = {c.get("id") for c in source}
    extra_stored = [c for c in stored if c.get("id") not in known and c.get("id") != "recorded-run"]
    used = set(known)
    for k, cell in enumerate(c for c in cells if c.get("id") not in known):
        tags = cell.get("metadata", {}).get("tags", [])
        same = [c for c in extra_stored if c.get("metadata", {}).get("tags", []) == tags]
        want = same[0]["id"] if same else ("injected-parameters" if "injected-parameters" in tags else f"cell-{k}")
        if same:
            extra_stored.remove(same[0])
        while want in used:
            want += "-1"
        cell["id"] = want
        used.add(want)


def _without_note(nb: dict) -> dict:
    return {**nb, "cells": [c for c in nb.get("cells", []) if c.get("id") != "recorded-run"]}


def recorded_copy(
    executed: str | Path, figures_dir: str | Path, out_dir: str | Path, source: str | Path | None = None
) -> dict:
    """The recorded copy (a notebook as a dict) of the executed chapter ``executed``, with
    figures referenced in ``figures_dir`` relative to ``out_dir`` where it will be stored, and
    cell ids of the chapter ``source`` and of the copy stored in ``out_dir`` (:func:`stable_ids`)."""
    executed, figures_dir, out_dir = Path(executed), Path(figures_dir), Path(out_dir)
    nb = _notebook(executed, "an executed notebook")
    cells = nb["cells"]
    stored = out_dir / executed.name
    stable_ids(
        cells,
        _notebook(Path(source), "a chapter")["cells"] if source is not None else None,
        _notebook(stored, "a recorded copy")["cells"] if stored.is_file() else [],
    )
    run = nb.get("metadata", {}).get("papermill", {})
    for cell in cells:
        meta = cell.get("metadata", {})
        for key in ("papermill", "execution", "ExecuteTime"):
            meta.pop(key, None)
        if cell["cell_type"] != "code":
            continue
        if SOLUTION_TAG in meta.get("tags", []):
            meta["tags"] = [*meta["tags"], *(t for t in SOLUTION_FOLD["tags"] if t not in meta["tags"])]
            meta["mystnb"] = dict(SOLUTION_FOLD["mystnb"])
        figures = saved_figures(cell, figures_dir)
        n_images = sum(n.endswith(".png") for n in figures)  # (a page of its own is never an inline image)
        cell["outputs"] = [_without_root(o) for o in compact_outputs(cell.get("outputs", []), n_images)]
        cell["outputs"] += [_reference(n, figures_dir, out_dir) for n in figures]
    params = run.get("parameters", {})
    mode = "quick" if params.get("quick") else "full"
    date = str(run.get("start_time") or "")[:10] or "an unrecorded date"
    note = (
        f"*A recorded run: the outputs below are those of `scripts/reproduce` ({mode} mode, {date}); "
        "its figures are the committed files in `figures/`. Each exercise shows the reference solution "
        "the grader below it passed, folded: the student edition has the stub instead.*"
    )
    at = 1 if cells and cells[0]["cell_type"] == "markdown" else 0
    cells.insert(at, {"cell_type": "markdown", "id": "recorded-run", "metadata": {}, "source": note})
    nb.setdefault("metadata", {})["papermill"] = {"parameters": params}
    nb["metadata"].pop("widgets", None)
    return nb


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("executed", nargs="+", help="executed chapters (build/notebooks/NN_*.ipynb)")
    parser.add_argument("--figures", required=True, help="the folder the run wrote its figures into")
    parser.add_argument("--out", required=True, help="where the recorded copies go")
    parser.add_argument("--source", default="notebooks", help="the source chapters, for the cell ids (notebooks)")
    args = parser.parse_args(argv)
    out_dir = Path(args.out)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        for path in args.executed:
            target = out_dir / Path(path).name
            if target.resolve() == Path(path).resolve():
                raise InputError(f"--out {out_dir}: the recorded copy would overwrite its input {path}")
            source = Path(args.source) / Path(path).name
            nb = recorded_copy(path, args.figures, out_dir, source if source.is_file() else None)
            if target.is_file() and _without_note(json.loads(target.read_text(encoding="utf-8"))) == _without_note(nb):
                print(f"recorded {path}: {target} unchanged (the same outputs)", file=sys.stderr)
                continue
            atomic_write_text(target, json.dumps(nb, indent=1, ensure_ascii=False) + "\n")
            print(f"recorded {path} -> {target} ({target.stat().st_size / 1e3:.0f} kB)", file=sys.stderr)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
