"""The package's folders are the paper's pipeline, and imports run one way.

Every import of a ``lab`` module -- at module level *or inside a function* -- is read from
the source with :mod:`ast`. Each module belongs to a layer (its top-level subpackage or
module under ``lab``); a module may import only from its own layer or from layers listed
before it in ``LAYERS``, and the module graph has no cycle. The same reading checks the
shape of the code: the rigs alone parse ``--rig`` strings, command modules stay thin and
independent, every subpackage declares ``__all__``, and no code cites an issue number.
"""

from __future__ import annotations

import ast
import functools
import importlib
import re
from pathlib import Path

import pytest

LAB = Path(__file__).resolve().parent.parent / "lab"

#: The pipeline, lowest first: description -> fem (mesh, energy, statics) -> data -> model
#: (learn) -> IK and trajectories (control) -> the as-built robots (asbuilt) -> rig -> capture
#: on a rig -> tracking -> studies; drawing, the commands' jobs and the CLI on top.
LAYERS = [
    "lab",
    "errors",
    "specs",
    "files",
    "workers",
    "startup",
    "description",
    "fem",
    "data",
    "learn",
    "dynamics",
    "control",
    "asbuilt",
    "rig",
    "capture",
    "transfer",
    "tracking",
    "studies",
    "peers",
    "viz",
    "jobs",
    "course",
    "cli",
    "__main__",
]
SUBPACKAGES = [
    "description",
    "fem",
    "fem.bodies",
    "fem.materials",
    "fem.actuators",
    "fem.solve",
    "fem.kernels",
    "data",
    "learn",
    "dynamics",
    "control",
    "asbuilt",
    "rig",
    "capture",
    "transfer",
    "tracking",
    "studies",
    "peers",
    "viz",
    "jobs",
    "course",
    "cli",
]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(LAB.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def is_module(name: str) -> bool:
    rel = Path(*name.split("."))
    return (LAB.parent / rel).is_dir() or (LAB.parent / rel.with_suffix(".py")).exists()


@functools.cache
def parsed(path: Path) -> ast.Module:
    """The syntax tree of the file ``path``, read once per session (the tests only walk it)."""
    return ast.parse(path.read_text())


def lab_imports(path: Path, name: str) -> set[str]:
    """Every lab module ``path`` (module ``name``) imports, resolved to module names."""
    tree = parsed(path)
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


@functools.cache
def graph() -> dict[str, frozenset[str]]:
    """Each lab module -> the lab modules it imports (computed once per session)."""
    files = {module_name(p): p for p in LAB.rglob("*.py")}
    return {name: frozenset({m for m in lab_imports(p, name) if m in files} - {name}) for name, p in files.items()}


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


def in_package(module: str, package: str) -> bool:
    """Whether ``module`` is ``lab.<package>`` or one of its modules."""
    return module == f"lab.{package}" or module.startswith(f"lab.{package}.")


#: the packages of the robot and its capture: the as-built robots, the rigs, capture on a rig
RIG_PACKAGES = ("asbuilt", "rig", "capture")


@pytest.mark.parametrize("package", RIG_PACKAGES)
def test_rig_does_not_import_learn(package):
    # A rig drives a robot; the foam's dynamics it needs live below it (lab.dynamics), not in the model stage.
    bad = [
        f"{a} imports {b}"
        for a, deps in graph().items()
        if in_package(a, package)
        for b in deps
        if in_package(b, "learn")
    ]
    assert not bad, bad


def test_rig_split_by_concern():
    # The rig interface, its drivers and emulators know nothing of capture; the as-built
    # robots know nothing of rigs or capture; capture works through the rig interface only,
    # never on the as-built robots behind a twin.
    forbidden = {"asbuilt": ("rig", "capture"), "rig": ("capture",), "capture": ("asbuilt",)}
    bad = [
        f"{a} imports {b}"
        for a, deps in graph().items()
        for package, others in forbidden.items()
        if in_package(a, package)
        for b in deps
        if any(in_package(b, o) for o in others)
    ]
    assert not bad, bad


def test_one_family_class():
    # The families of as-built robots are parameter draws of one Family, not parallel copies.
    from lab.asbuilt import FAMILIES, Family

    assert set(FAMILIES) == {"random", "foam", "pneumatic"} and all(type(f) is Family for f in FAMILIES.values())
    classes = [
        f"{module_name(p)}.{n.name}"
        for p in sorted(LAB.rglob("*.py"))
        if in_package(module_name(p), "asbuilt") or in_package(module_name(p), "rig")
        for n in ast.walk(parsed(p))
        if isinstance(n, ast.ClassDef) and "Family" in n.name and not n.name.endswith("Spec")
    ]
    assert sorted(classes) == ["lab.asbuilt.family.Family", "lab.rig.twin.FamilyTwinRig"], classes


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
        "from .model import ArmFEM\nfrom ..description import load_robot\n"
        "def f():\n    from lab.learn import mlp\n    import lab.data.dataset\n"
    )
    f = tmp_path / "x.py"
    f.write_text(src)
    assert lab_imports(f, "lab.fem.x") == {"lab.fem.model", "lab.description", "lab.learn.mlp", "lab.data.dataset"}


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


# --- the command line: one thin module per command --------------------------------------

#: the most lines a command's ``run`` may have: it reads its settings and calls the stages
RUN_MAX_LINES = 40


def command_modules() -> dict[str, str]:
    """Command name -> module name, from :data:`lab.cli.COMMANDS`."""
    import lab.cli

    return {cmd: m if isinstance(m, str) else m.__name__ for cmd, m in lab.cli.COMMANDS.items()}


def cli_path_to_command(g: dict[str, set[str]], start: str, commands: set[str]) -> list[str] | None:
    """The import chain from command module ``start`` to another command module through
    shared ``lab.cli`` helper modules, or None."""
    seen, todo = {start}, [[start]]
    while todo:
        chain = todo.pop(0)
        for m in sorted(g.get(chain[-1], ())):
            if m in seen or not m.startswith("lab.cli.") or m == "lab.cli":
                continue
            if m in commands:
                return chain + [m]
            seen.add(m)
            todo.append(chain + [m])
    return None


def test_commands_do_not_import_each_other():
    # Code two commands share lives in a helper module of lab/cli (paths, signals, flags, ...)
    # or in the stages, never in another command's module.
    commands = set(command_modules().values())
    g = graph()
    bad = [" -> ".join(chain) for c in sorted(commands) if (chain := cli_path_to_command(g, c, commands))]
    assert not bad, "command modules importing other command modules:\n" + "\n".join(bad)


def test_command_run_is_short():
    long = {}
    for module in sorted(set(command_modules().values())):
        path = LAB.parent / Path(*module.split("."))
        path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
        runs = [n for n in parsed(path).body if isinstance(n, ast.FunctionDef) and n.name == "run"]
        assert runs, f"{module} has no run(args) function"
        if (n := runs[0].end_lineno - runs[0].lineno + 1) > RUN_MAX_LINES:
            long[module] = n
    assert not long, f"run() over {RUN_MAX_LINES} lines: {long}"


def test_one_job_per_command():
    # lab/jobs/<command>.py for each command, with one entry point ``run``; the command's
    # module imports it, and jobs never import each other (what two share lives in a stage).
    import lab.jobs

    commands = command_modules()
    assert {c: m.__name__ for c, m in lab.jobs.JOBS.items()} == {
        c: f"lab.jobs.{c.replace('-', '_')}" for c in commands
    }, "lab.jobs.JOBS does not map each command to its job module"
    jobs_dir = LAB / "jobs"
    expected = {cmd.replace("-", "_") for cmd in commands}
    present = {p.stem for p in jobs_dir.glob("*.py") if p.name != "__init__.py"}
    assert present == expected, f"lab/jobs modules {sorted(present)} != the commands {sorted(expected)}"
    g = graph()
    for cmd, cli_module in commands.items():
        job = f"lab.jobs.{cmd.replace('-', '_')}"
        tree = parsed(jobs_dir / f"{job.rpartition('.')[2]}.py")
        runs = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "run"]
        assert runs, f"{job} has no run(spec, ...) function"
        assert job in g[cli_module], f"{cli_module} does not import {job}"
        others = sorted(m for m in g[job] if m.startswith("lab.jobs") and m != job)
        assert not others, f"{job} imports other jobs: {others}"


# --- the FEM's solve works through the body, material and actuator interfaces -------------

#: The solve modules: they see the assembled model (lab.fem.model) and the actuators'
#: interface (lab.fem.actuators.base), never one kind of actuator.
FEM_SOLVE = ["lab.fem.solve.statics", "lab.fem.solve.steps", "lab.fem.solve.warmstart"]


def code_names(path: Path) -> set[str]:
    """Every identifier in the code of ``path`` (names, attributes, arguments; not docstrings)."""
    tree = parsed(path)
    out = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.Name):
            out.add(n.id)
        elif isinstance(n, ast.Attribute):
            out.add(n.attr)
        elif isinstance(n, ast.arg):
            out.add(n.arg)
        elif isinstance(n, ast.alias):
            out.add(n.name)
    return out


@pytest.mark.parametrize("module", FEM_SOLVE)
def test_fem_solve_knows_no_actuator_kind(module):
    deps = graph()[module]
    kinds = sorted(d for d in deps if d.startswith("lab.fem.actuators") and d != "lab.fem.actuators.base")
    assert not kinds, f"{module} imports a kind of actuator: {kinds}"
    path = LAB.parent / Path(*module.split(".")).with_suffix(".py")
    specific = sorted(n for n in code_names(path) if re.search("cable|spring|motor_angle|spool|robot", n, re.I))
    assert not specific, f"{module} names cable-specific things in its code: {specific}"


def test_a_toy_actuator_plugs_in_without_solver_edits():
    """tests/test_fem_interfaces.py registers its own actuator and solves with it, patching
    nothing in lab.fem."""
    path = LAB.parent / "tests" / "test_fem_interfaces.py"
    tree = parsed(path)
    registered = [
        c.name
        for c in ast.walk(tree)
        if isinstance(c, ast.ClassDef) and any("register_actuator" in ast.unparse(d) for d in c.decorator_list)
    ]
    assert registered, "the interface test registers no actuator of its own"
    assert not ({"monkeypatch", "setattr"} & code_names(path)), "the interface test patches the package"
    tests = {f.name for f in tree.body if isinstance(f, ast.FunctionDef) and f.name.startswith("test_")}
    assert {"test_point_force_sensitivity_matches_central_differences", "test_two_kinds_of_actuator_at_once"} <= tests


# --- the --rig grammar is read in lab/rig only ------------------------------------------

#: a literal in the --rig grammar: ``twin:...``, ``hardware:...``, ``random:...``, ``sim:...``
RIG_LITERAL = re.compile(r"^(sim|twin|hardware|random):")


def _rig_named(node: ast.AST) -> bool:
    """Whether an expression is a rig string by its name: ``rig``, ``args.rig``, ``str(spec)``,
    ``rig_spec`` -- not a field of a parsed spec such as ``rig_spec.kind``."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "str" and node.args:
        return _rig_named(node.args[0])
    name = node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute) else ""
    return name in ("rig", "spec", "rig_spec")


def _str_literals(node: ast.AST) -> list[str]:
    items = node.elts if isinstance(node, ast.Tuple | ast.List | ast.Set) else [node]
    return [i.value for i in items if isinstance(i, ast.Constant) and isinstance(i.value, str)]


def rig_string_parsing(source: str) -> list[tuple[int, str]]:
    """(line, code) of every place ``source`` takes a ``--rig`` string apart: a ``":"`` split or
    partition of a rig-named value, a prefix test or comparison against a literal of the rig
    grammar (``"twin:"``, ``"hardware:"``, ...), or a rig-named value tested against any string
    literal. Help and error texts that only mention the forms are not parsing."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            method, receiver, args = node.func.attr, node.func.value, node.args
            literals = [v for a in args for v in _str_literals(a)]
            if method in ("partition", "rpartition", "split", "rsplit") and literals[:1] == [":"]:
                hit = _rig_named(receiver)
            elif method in ("startswith", "endswith"):
                hit = any(RIG_LITERAL.match(v) for v in literals) or (bool(literals) and _rig_named(receiver))
            else:
                continue
        elif isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            literals = [v for o in operands for v in _str_literals(o)]
            hit = any(RIG_LITERAL.match(v) for v in literals) or (
                bool(literals) and any(_rig_named(o) for o in operands if not _str_literals(o))
            )
        else:
            continue
        if hit:
            found.append((node.lineno, ast.unparse(node)))
    return sorted(found)


def test_rig_parser_finder():
    src = (
        'kind, _, arg = str(spec).partition(":")\n'
        'f = args.rig.partition(":")[2]\n'
        'a = arg.startswith("random:")\n'
        'b = args.rig == "sim"\n'
        'c = rig.startswith("twin")\n'
        'd = label in ("hardware:x", "y")\n'
        'p.add_argument("--rig", help="sim, twin, twin:DEFECTS.toml, twin:random:SEED or hardware:RIG.toml")\n'
        'raise InputError(f"rig {rig!r}: expected twin:random:SEED")\n'
        'e = f"random:{k}"\n'
        'g = name.split(":")\n'
        'h = mode == "sim-only"\n'
        'i = rig_spec.kind != "twin"\n'
    )
    assert [line for line, _ in rig_string_parsing(src)] == [1, 2, 3, 4, 5, 6]


def test_only_rigs_parse_rig_strings():
    bad = [
        f"{module_name(p)}:{line}: {code}"
        for p in sorted(LAB.rglob("*.py"))
        if not in_package(module_name(p), "rig")
        for line, code in rig_string_parsing(p.read_text())
    ]
    assert not bad, "--rig strings taken apart outside lab/rig (use lab.rig's parser):\n" + "\n".join(bad)


# --- every subpackage exports, no issue numbers -------------------------------------------


def declares_all(path: Path) -> bool:
    """Whether the module at ``path`` assigns ``__all__`` at its top level."""
    for node in parsed(path).body:
        targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
        if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
            return True
    return False


def test_every_subpackage_declares_all():
    packages = sorted(p.parent for p in LAB.rglob("__init__.py") if p.parent != LAB)
    unlisted = [p.name for p in packages if p.parent == LAB and p.name not in SUBPACKAGES]
    assert not unlisted, f"subpackages missing from SUBPACKAGES: {unlisted}"
    missing = [module_name(p / "__init__.py") for p in packages if not declares_all(p / "__init__.py")]
    assert not missing, f"subpackages without __all__: {missing}"


#: "issue 12", "issues 3", "issue #4": the history lives in git and docs/design, not in the code
ISSUE_CITATION = re.compile(r"\bissues?\s*#?\d+", re.IGNORECASE)


def test_no_issue_numbers_in_code_or_readme():
    files = [p for p in LAB.rglob("*") if p.is_file() and "__pycache__" not in p.parts]
    files.append(LAB.parent / "README.md")
    bad = []
    for p in sorted(files):
        try:
            text = p.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        for i, line in enumerate(text.splitlines(), 1):
            if m := ISSUE_CITATION.search(line):
                bad.append(f"{p.relative_to(LAB.parent)}:{i}: {m.group(0)}")
    assert not bad, f"{len(bad)} issue citations:\n" + "\n".join(bad)


def test_no_test_named_after_an_issue():
    bad = [
        f"{p.name}::{n.name}"
        for p in sorted((LAB.parent / "tests").rglob("*.py"))
        for n in ast.walk(parsed(p))
        if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef)
        and re.search(r"issues?_?\d+", n.name, re.IGNORECASE)
    ]
    assert not bad, f"tests named after issue numbers: {bad}"


# --- the stages speak their own fields; only the command line and its jobs name flags -------

#: A command-line flag in a message: ``--period-s``, ``--rig``.
FLAG = re.compile(r"(?<![\w-])--[a-z]")
#: Where messages may name flags: the command line and the jobs it runs.
FLAG_SPEAKERS = ("cli", "jobs")
#: Calls that build an error: ``InputError(...)``, ``LabRuntimeError(...)``, ``spec.field_error(...)``.
_ERROR_CALL = re.compile(r"(Error|Exception|field_error)$")


def error_messages(source: str) -> list[tuple[int, str]]:
    """(line, text) of every string literal (f-strings' literal parts too) in a ``raise``
    statement or in a call that builds an error (``InputError(...)``, ``field_error(...)``)."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        exprs = []
        if isinstance(node, ast.Raise) and node.exc is not None:
            exprs.append(node.exc)
        elif isinstance(node, ast.Call):
            func = node.func
            name = func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else ""
            if _ERROR_CALL.search(name):
                exprs.append(node)
        for expr in exprs:
            for sub in ast.walk(expr):
                if isinstance(sub, ast.Constant) and isinstance(sub.value, str):
                    found.add((sub.lineno, sub.value))
    return sorted(found)


def test_error_message_finder():
    source = (
        "def f(x):\n"
        "    if x:\n"
        "        raise InputError(f'--period-s {x} is bad')\n"
        "    err = FieldError('Spec.a goes with --b', 'Spec.a')\n"
        "    raise self.field_error(f'{x} --c-d')\n"
        "    print('--not-an-error')\n"
    )
    texts = [t for _, t in error_messages(source)]
    assert [t for t in texts if FLAG.search(t)] == ["--period-s ", "Spec.a goes with --b", " --c-d"]


def test_stage_errors_name_no_flags():
    """A notebook that builds a spec gets errors about its fields (``TrackSpec.period_s``),
    never about flags it did not type: only lab/cli and lab/jobs name flags."""
    found = []
    for path in sorted(LAB.rglob("*.py")):
        if path.relative_to(LAB).parts[0] in FLAG_SPEAKERS:
            continue
        for line, text in error_messages(path.read_text()):
            if FLAG.search(text):
                found.append(f"{path.relative_to(LAB.parent)}:{line}: {text!r}")
    assert not found, "stage errors naming a flag:\n" + "\n".join(found)
