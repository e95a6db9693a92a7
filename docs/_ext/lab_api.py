"""The API reference of the documentation site, generated from each module's ``__all__``.

``.. lab-api:: lab.fem`` (in docs/api/lab.fem.rst) documents one module of the package: its
docstring, then every name of its ``__all__`` in order, under the name a user imports it by
(``lab.fem.solve_static``, whatever module defines it): functions and classes through
autodoc (signatures with their annotations; napoleon reads the numpy-style Parameters and
Returns sections, with their units and shapes), constants as ``py:data`` with their value and
the ``#:`` comment where they are defined. Then a "Modules" section gives each submodule's
docstring (the targets of ``:mod:`` references). Nothing is listed by hand, so a name added
to ``__all__`` is on the site at the next build (tests/test_docs_site.py checks every one).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import re
import sys
import types

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.pycode import ModuleAnalyzer
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import make_refnode, nested_parse_with_titles

#: Per build environment: id(object) -> public name (see _documented_by_object).
_BY_OBJECT: dict[int, dict[int, str]] = {}
#: Longest value shown for a constant (characters of its repr).
VALUE_CHARS = 100
#: Levels of an API page's table of contents: the page, then its names (not their members).
TOC_DEPTH = 2


def public_names(module: types.ModuleType) -> list[str]:
    """The names ``module`` exports: its ``__all__``, else its public functions and classes."""
    names = getattr(module, "__all__", None)
    if names is not None:
        return list(names)
    return [
        n
        for n, o in vars(module).items()
        if not n.startswith("_") and (inspect.isfunction(o) or inspect.isclass(o)) and o.__module__ == module.__name__
    ]


def submodules(module: types.ModuleType) -> list[str]:
    """The modules of package ``module`` (none for a plain module), by name, those of its
    subpackages included."""
    if not hasattr(module, "__path__"):
        return []
    found = pkgutil.walk_packages(module.__path__, f"{module.__name__}.")
    return sorted(m.name for m in found if m.name.rsplit(".", 1)[1] != "__main__")


def _attr_doc(module: types.ModuleType, name: str) -> list[str]:
    """The ``#:`` comment (or docstring after the assignment) of constant ``name``, searched
    in ``module`` and in the loaded modules of its package."""
    value = getattr(module, name)
    prefix = module.__name__.split(".")[0] + "."
    for modname in [module.__name__, *sorted(m for m in list(sys.modules) if m.startswith(prefix))]:
        mod = sys.modules.get(modname)
        if mod is None or getattr(mod, name, None) is not value:
            continue
        try:
            docs = ModuleAnalyzer.for_module(modname).find_attr_docs()
        except Exception:  # a module without source (compiled, namespace)
            continue
        if ("", name) in docs:
            return [line for line in docs[("", name)] if line is not None]
    return []


def _commented_constants(modname: str) -> list[str]:
    """The module-level names of ``modname`` with a ``#:`` comment, in source order."""
    try:
        docs = ModuleAnalyzer.for_module(modname).find_attr_docs()
    except Exception:
        return []
    return [name for (scope, name) in docs if scope == "" and not name.startswith("_")]


def _value(obj) -> str:
    text = " ".join(repr(obj).split())
    return text if len(text) <= VALUE_CHARS else text[: VALUE_CHARS - 4] + " ..."


def api_lines(modname: str) -> list[str]:
    """The reStructuredText of module ``modname``'s reference."""
    module = importlib.import_module(modname)
    lines = [f".. automodule:: {modname}", ""]
    for name in public_names(module):
        obj = getattr(module, name)
        full = f"{modname}.{name}"
        if inspect.isclass(obj):
            lines += [f".. autoclass:: {full}", "   :members:", "   :show-inheritance:", ""]
        elif callable(obj):
            lines += [f".. autofunction:: {full}", ""]
        else:
            lines += [f".. py:data:: {name}", f"   :module: {modname}", f"   :value: {_value(obj)}", ""]
            lines += [f"   {line}" for line in plain_text_math(_attr_doc(module, name))] + [""]
    subs = submodules(module)
    if subs:
        lines += ["Modules", "-------", ""]
        exported = {id(getattr(module, n)) for n in public_names(module)}
        for sub in subs:
            submodule = importlib.import_module(sub)
            # the module's own names that are not exported above: its functions and classes,
            # and its constants (listed in its __all__, or with a ``#:`` comment)
            names = public_names(submodule)
            if not hasattr(submodule, "__all__"):
                names += _commented_constants(sub)
            own = []
            for n in dict.fromkeys(names):
                obj = getattr(submodule, n, None)
                if inspect.isclass(obj) or inspect.isfunction(obj):
                    if id(obj) not in exported and obj.__module__ == sub:
                        own.append(n)
                elif obj is not None and not inspect.ismodule(obj) and getattr(module, n, None) is not obj:
                    own.append(n)
            # (a subpackage's modules come after it: what it documents, they do not repeat)
            exported |= {id(getattr(submodule, n)) for n in own if inspect.isclass(getattr(submodule, n))}
            exported |= {id(getattr(submodule, n)) for n in own if inspect.isfunction(getattr(submodule, n))}
            lines += [f".. rubric:: ``{sub}``", "", f".. automodule:: {sub}"]
            # (a module named like a function its package exports, lab.learn.train: that
            # name is the function's, so the module gets no target of its own)
            leaf = sub.rsplit(".", 1)[1]
            if hasattr(module, leaf) and not inspect.ismodule(getattr(module, leaf)):
                lines += ["   :no-index:"]
            if own:
                lines += [f"   :members: {', '.join(own)}"]
            lines += [""]
    return lines


def _resolve(dotted: str):
    """The object a dotted ``lab.x.y.Name.attr`` path names, or None. An attribute of a
    package wins over its submodule of the same name (``lab.learn.train`` is the function)."""
    parts = dotted.split(".")
    try:
        obj = importlib.import_module(parts[0])
        for i, name in enumerate(parts[1:], start=2):
            if inspect.ismodule(obj) and not hasattr(obj, name):
                importlib.import_module(".".join(parts[:i]))
            obj = inspect.getattr_static(obj, name) if inspect.isclass(obj) else getattr(obj, name)
        return obj
    except (ImportError, AttributeError):
        pass
    for i in range(len(parts) - 1, 0, -1):  # a module, then attributes of it
        try:
            obj = importlib.import_module(".".join(parts[:i]))
            for name in parts[i:]:
                obj = inspect.getattr_static(obj, name) if inspect.isclass(obj) else getattr(obj, name)
            return obj
        except (ImportError, AttributeError):
            continue
    return None


def _documented_by_object(env) -> dict[int, str]:
    """id(object) -> the public name it is documented under, for functions, classes and
    their members (not plain values: equal numbers are not the same constant)."""
    cache = _BY_OBJECT.get(id(env))
    if cache is None:
        cache = _BY_OBJECT[id(env)] = {}
        for name, entry in env.get_domain("py").objects.items():
            if entry.objtype in ("module", "data") or getattr(entry, "aliased", False):
                continue
            obj = _resolve(name)
            if obj is not None and not isinstance(obj, (int, float, str, tuple, bool, type(None))):
                cache.setdefault(id(obj), name)
    return cache


def resolve_by_definition(app, env, node, contnode):
    """A reference to where a name is defined (``lab.learn.train_spec.TrainSpec``, a method through
    its defining module) resolves to the entry of the public name it is documented under
    (``lab.learn.TrainSpec``)."""
    if node.get("refdomain") != "py" or not node.get("reftarget", "").startswith("lab."):
        return None
    target, objects, by_object = node["reftarget"], env.get_domain("py").objects, _documented_by_object(env)
    parts = target.split(".")
    public = None
    for k in range(len(parts), 1, -1):  # the object, else its class and the attribute's name
        obj = _resolve(".".join(parts[:k]))
        if obj is not None and id(obj) in by_object:
            public = ".".join([by_object[id(obj)], *parts[k:]])
            break
    if public is None and node.get("reftype") in ("data", "obj", "const"):
        value, leaf = _resolve(target), parts[-1]
        same = [n for n, e in objects.items() if e.objtype == "data" and n.endswith("." + leaf) and n != target]
        public = next((n for n in same if _resolve(n) is value), None)
    if public not in objects:
        return None
    entry = objects[public]
    return make_refnode(app.builder, node["refdoc"], entry.docname, entry.node_id, contnode, public)


class LabApi(SphinxDirective):
    """``.. lab-api:: MODULE``: the module's reference (see the module docstring)."""

    required_arguments = 1
    has_content = False

    def run(self) -> list[nodes.Node]:
        modname = self.arguments[0]
        source, line = self.get_source_info()
        content = StringList([*api_lines(modname)], source=source)
        node = nodes.container()
        nested_parse_with_titles(self.state, content, node)
        for name in [modname, *submodules(importlib.import_module(modname))]:  # rebuilt when one changes
            self.env.note_dependency(importlib.import_module(name).__file__)
        # The page's table of contents lists its functions, classes and constants, not their
        # members (the page's own :tocdepth:): Sphinx copies every page's table for every
        # page's sidebar, and the members (lab.fem's: 320 of 382 entries) made that a quarter
        # of a build (74 -> 54 s).
        self.env.metadata[self.env.docname].setdefault("tocdepth", TOC_DEPTH)
        return node.children


_ORIGINAL: dict[int, list[str]] = {}
#: Inline literals and roles, which keep their text as it is.
_LITERAL = re.compile(r"(``.+?``|:[\w:]+:`[^`]+`|`[^`]+`_?)")
#: The first line of an example block: a command to type.
_COMMAND = re.compile(r"\s+(\$ |python |scripts/|\.venv/)")


def plain_text_math(lines: list[str]) -> list[str]:
    """The project's docstrings write absolute values and norms as ``|x - y|``: escape the
    bars (reStructuredText would read substitutions), except inside literals and roles."""
    out = []
    for line in lines:
        parts = _LITERAL.split(line)
        out.append("".join(p if i % 2 else p.replace("|", "\\|") for i, p in enumerate(parts)))
    return out


def command_blocks(lines: list[str]) -> list[str]:
    """An indented block of commands after a paragraph (the modules' usage lines) is shown
    as typed: a literal block (a lone ``::`` before it), not a quotation."""
    out = []
    for i, line in enumerate(lines):
        prev = next((q for q in reversed(lines[:i]) if q.strip()), "")
        if (
            _COMMAND.match(line)
            and i > 0
            and not lines[i - 1].strip()
            and len(line) - len(line.lstrip()) > len(prev) - len(prev.lstrip())
            and not prev.rstrip().endswith("::")
        ):
            out += ["::", ""]
        out.append(line)
    return out


def _normalise(app, what, name, obj, options, lines):
    lines[:] = command_blocks(plain_text_math(lines))


def _keep_attribute_docstring(app, what, name, obj, options, lines):
    """Before napoleon: remember an attribute's or property's docstring. Napoleon reads a
    first line "The journal: ..." as "type: description"; these docstrings are prose."""
    if what in ("attribute", "property", "data"):
        _ORIGINAL[id(lines)] = list(lines)


def _restore_attribute_docstring(app, what, name, obj, options, lines):
    original = _ORIGINAL.pop(id(lines), None)
    if original is not None:
        lines[:] = original


def _factory_defaults(app, what, name, obj, options, signature, return_annotation):
    """A dataclass field's ``default_factory`` shows as ``<factory>``, which no signature
    parser reads: show the call that makes the default (``MeshSpec()``), else ``...``."""
    if not signature or "<factory>" not in signature or not dataclasses.is_dataclass(obj):
        return None
    for f in dataclasses.fields(obj):
        if f.init and f.default_factory is not dataclasses.MISSING:
            made = getattr(f.default_factory, "__qualname__", "")
            signature = signature.replace("<factory>", f"{made}()" if made.isidentifier() else "...", 1)
    return signature.replace("<factory>", "..."), return_annotation


def setup(app):
    app.connect("autodoc-process-signature", _factory_defaults)
    app.connect("autodoc-process-docstring", _normalise, priority=390)
    app.connect("autodoc-process-docstring", _keep_attribute_docstring, priority=400)
    app.connect("autodoc-process-docstring", _restore_attribute_docstring, priority=600)
    app.add_directive("lab-api", LabApi)
    app.connect("missing-reference", resolve_by_definition)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
