"""The package's folders are the paper's pipeline, and imports run one way.

Every import of a ``lab`` module -- at module level *or inside a function* -- is read from
the source with :mod:`ast`. Each module belongs to a layer (its top-level subpackage or
module under ``lab``); a module may import only from its own layer or from layers listed
before it in ``LAYERS``, and the module graph has no cycle.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

LAB = Path(__file__).resolve().parent.parent / "lab"

#: The pipeline, lowest first: description -> fem (mesh, energy, statics) -> data -> model
#: (learn) -> IK and trajectories (control) -> rig -> tracking; drawing and the CLI on top.
LAYERS = [
    "lab",
    "errors",
    "files",
    "workers",
    "description",
    "fem",
    "data",
    "learn",
    "control",
    "rig",
    "transfer",
    "tracking",
    "peers",
    "viz",
    "course",
    "cli",
    "__main__",
]
SUBPACKAGES = ["fem", "data", "learn", "control", "rig", "transfer", "tracking", "peers", "viz", "cli"]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(LAB.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def is_module(name: str) -> bool:
    rel = Path(*name.split("."))
    return (LAB.parent / rel).is_dir() or (LAB.parent / rel.with_suffix(".py")).exists()


def lab_imports(path: Path, name: str) -> set[str]:
    """Every lab module ``path`` (module ``name``) imports, resolved to module names."""
    tree = ast.parse(path.read_text())
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == "lab"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.split(".")[0] != "lab":
                continue
            subs = {f"{mod}.{a.name}" for a in node.names if is_module(f"{mod}.{a.name}")}
            out |= subs
            if len(subs) < len(node.names):  # names from the module itself, not only its submodules
                out.add(mod)
    return out


def graph() -> dict[str, set[str]]:
    files = {module_name(p): p for p in LAB.rglob("*.py")}
    return {name: {m for m in lab_imports(p, name) if m in files} - {name} for name, p in files.items()}


def layer(module: str) -> int:
    parts = module.split(".")
    return LAYERS.index(parts[1] if len(parts) > 1 else "lab")


def test_every_module_has_a_layer():
    for name in graph():
        layer(name)  # ValueError for a module outside the pipeline


def test_imports_run_down_the_pipeline():
    bad = [f"{a} imports {b}" for a, deps in graph().items() for b in deps if layer(b) > layer(a)]
    assert not bad, "imports against the pipeline order:\n" + "\n".join(sorted(bad))


def test_control_does_not_import_learn():
    # IK takes any forward map with a Jacobian; it must not depend on the MLP.
    bad = [
        f"{a} imports {b}"
        for a, deps in graph().items()
        if a.startswith("lab.control")
        for b in deps
        if b.startswith("lab.learn")
    ]
    assert not bad, bad


def find_cycle(g: dict[str, set[str]]) -> list[str] | None:
    state, stack = {}, []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for m in sorted(g[n]):
            if state.get(m) == 1:
                return stack[stack.index(m) :] + [m]
            if m not in state and (c := visit(m)):
                return c
        state[n] = 2
        stack.pop()
        return None

    for n in sorted(g):
        if n not in state and (c := visit(n)):
            return c
    return None


def test_no_import_cycles():
    cycle = find_cycle(graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_cycle_finder_finds_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_import_reader_resolves_relative_and_function_level_imports(tmp_path, monkeypatch):
    src = (
        "from .energy import ArmFEM\nfrom ..description import load_robot\n"
        "def f():\n    from lab.learn import mlp\n    import lab.data.dataset\n"
    )
    f = tmp_path / "x.py"
    f.write_text(src)
    assert lab_imports(f, "lab.fem.x") == {"lab.fem.energy", "lab.description", "lab.learn.mlp", "lab.data.dataset"}


@pytest.mark.parametrize("package", SUBPACKAGES)
def test_subpackage_exports(package):
    mod = importlib.import_module(f"lab.{package}")
    assert (mod.__doc__ or "").strip(), f"lab.{package} has no docstring"
    if package == "cli":
        assert callable(mod.main)
        return
    assert mod.__all__, f"lab.{package} exports nothing"
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert not missing, f"lab.{package}.__all__ names missing attributes: {missing}"


def test_modules_stay_small():
    # One concept per module: about 300 lines (formatted by ruff); 400 is the hard limit.
    big = {module_name(p): n for p in LAB.rglob("*.py") if (n := len(p.read_text().splitlines())) > 400}
    assert not big, f"modules over 400 lines: {big}"


def test_errors_derive_from_lab_error():
    import inspect
    import pkgutil

    import lab
    from lab.errors import LabError

    for info in pkgutil.walk_packages(lab.__path__, "lab."):
        if info.name.endswith("__main__"):
            continue
        mod = importlib.import_module(info.name)
        for name, obj in vars(mod).items():
            if (
                inspect.isclass(obj)
                and obj.__module__ == mod.__name__
                and issubclass(obj, Exception)
                and not issubclass(obj, Warning)
            ):
                assert issubclass(obj, LabError), f"{info.name}.{name} does not derive from LabError"
