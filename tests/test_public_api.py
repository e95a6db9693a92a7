"""The public surface is what other code uses: every exported name has a user outside its module.

A name in a subpackage's ``__all__`` must be referenced in another module of ``lab``, a
chapter, a script, a benchmark or an example -- tests do not count, they import from the
defining module. The few names exported for users alone (an exception a caller catches, an
entry point the docs name) are listed in :data:`EXPORT_EXCEPTIONS` with the reason.
"""

from __future__ import annotations

import importlib
import json
import pkgutil
import re
from pathlib import Path

import lab

ROOT = Path(__file__).resolve().parent.parent

#: Exported names with no user in the repository, and why they are public all the same.
EXPORT_EXCEPTIONS: dict[str, str] = {
    "lab.fem.bodies.MeshBody": "the body a user builds from a mesh of their own and passes to ArmFEM(robot, body=...); "
    "the description's own comes from body_of",
    "lab.fem.bodies.TaperedBody": "the body a user builds at another resolution and passes to ArmFEM(robot, body=...); "
    "the description's own comes from body_of",
    "lab.jobs.JOBS": "command name -> job module: how a notebook or script finds the run(spec) of a command "
    "it knows by its CLI name (lab.cli.COMMANDS's counterpart)",
    "lab.learn.TrainResult": "what train() returns (model, split, log, errors); its signature names it, so the "
    "site's nitpicky reference needs the entry",
    "lab.peers.MujocoArm": "what mujoco_arm() returns, the object a user drives; the module shares the "
    "function's name, so the site has no other entry for it",
    "lab.peers.SettleResult": "what MujocoArm.settle() returns, read after settling; no other entry on the site",
    "lab.studies.Table1Error": "the error update_table1 raises for a table1.csv that is not Table I's; "
    "callers that merge results catch it",
    "lab.tracking.StreamPlan": "the type of StreamResult.knots, which a user reads from a streamed run",
    "lab.viz.stop_visualizer": "meshcat_scene's docstring tells callers to stop the visualizer it made with "
    "it (meshcat's own close() leaves the server running)",
}


def _texts() -> dict[Path, str]:
    out = {}
    for pattern in ("lab/**/*.py", "notebooks/*.ipynb", "scripts/*", "benchmarks/*.py", "examples/**/*.py"):
        for p in ROOT.glob(pattern):
            if not p.is_file() or "__pycache__" in p.parts:
                continue
            text = p.read_text(errors="ignore")
            if p.suffix == ".ipynb":
                text = "\n".join("".join(c["source"]) for c in json.loads(text)["cells"])
            out[p.resolve()] = text
    return out


def unused_exports() -> list[str]:
    """``lab.pkg.Name`` for every exported name no other file references (by whole word)."""
    words = {p: set(re.findall(r"\w+", t)) for p, t in _texts().items()}  # a name is a whole word
    unused = []
    for info in pkgutil.walk_packages(lab.__path__, "lab."):
        if not info.ispkg:
            continue
        package = importlib.import_module(info.name)
        for name in getattr(package, "__all__", ()):
            obj = getattr(package, name)
            home = {Path(package.__file__).resolve()}
            module = getattr(obj, "__module__", None)
            if isinstance(module, str) and module.startswith("lab"):
                home.add(Path(importlib.import_module(module).__file__).resolve())
            if not any(name in w for p, w in words.items() if p not in home):
                unused.append(f"{info.name}.{name}")
    return unused


def test_every_export_is_used_outside_its_module():
    unused = [n for n in unused_exports() if n not in EXPORT_EXCEPTIONS]
    assert not unused, "exported but used nowhere else (un-export, or justify in EXPORT_EXCEPTIONS):\n" + "\n".join(
        unused
    )


def test_exceptions_are_still_exported():
    stale = []
    for qual in EXPORT_EXCEPTIONS:
        package, _, name = qual.rpartition(".")
        if name not in getattr(importlib.import_module(package), "__all__", ()):
            stale.append(qual)
    assert not stale, f"EXPORT_EXCEPTIONS lists names no longer exported: {stale}"
