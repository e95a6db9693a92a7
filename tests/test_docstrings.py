"""Every public definition documents its inputs and outputs in numpydoc sections.

A public definition is a function or class named in a subpackage's ``__all__``, and each
public method of such a class. Its docstring needs a ``Parameters`` section when it takes
arguments (``self``/``cls`` aside; for a class, its constructor's; ``Attributes`` serves a
dataclass) and a ``Returns`` (or ``Yields``) section when it returns something (a function
annotated ``-> None`` and a class need none). The sections are rendered by the site's
napoleon and must parse as reStructuredText without a warning.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import io
import pkgutil
import re

import lab

#: The share of public definitions whose docstrings have the sections they need; the goal is all.
MIN_SHARE = 1.0

_SECTION = re.compile(r"^(Parameters|Returns|Yields|Attributes|Raises|Notes|Examples|See Also)\n-{3,}\s*$", re.M)


def public_definitions() -> dict[str, object]:
    """Qualified name -> function or class, for every definition a subpackage exports."""
    out = {}
    for info in pkgutil.walk_packages(lab.__path__, "lab."):
        if not info.ispkg or info.name.endswith("__main__"):
            continue
        mod = importlib.import_module(info.name)
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            qual = f"{obj.__module__}.{obj.__qualname__}"
            out[qual] = obj
            if inspect.isclass(obj):
                for attr, value in vars(obj).items():
                    if attr.startswith("_"):
                        continue
                    func = value.__func__ if isinstance(value, staticmethod | classmethod) else value
                    if inspect.isfunction(func):
                        out[f"{qual}.{attr}"] = func
    return out


def _takes_arguments(obj) -> bool:
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return False
    names = [p for p in sig.parameters if p not in ("self", "cls")]
    return bool(names)


def _returns_something(func) -> bool:
    if inspect.isgeneratorfunction(func):
        return True
    ret = inspect.signature(func).return_annotation
    return ret not in (None, "None")


def missing_sections(obj) -> list[str]:
    """The numpydoc sections ``obj``'s docstring lacks (empty when it is complete)."""
    doc = inspect.getdoc(obj) or ""
    sections = set(_SECTION.findall(doc))
    missing = []
    if _takes_arguments(obj) and not (sections & {"Parameters", "Attributes"}):
        if not (inspect.isclass(obj) and dataclasses.is_dataclass(obj) and "Attributes" in sections):
            missing.append("Parameters")
    if inspect.isfunction(obj) and _returns_something(obj) and not (sections & {"Returns", "Yields"}):
        missing.append("Returns")
    return missing


def rst_problems(obj) -> list[str]:
    """Warnings docutils raises on ``obj``'s docstring as napoleon renders it."""
    import docutils.core
    import docutils.utils
    from sphinx.ext.napoleon import Config
    from sphinx.ext.napoleon.docstring import NumpyDocstring

    doc = inspect.getdoc(obj) or ""
    rst = str(NumpyDocstring(doc, Config(napoleon_use_param=False, napoleon_use_rtype=False)))
    stream = io.StringIO()
    docutils.core.publish_doctree(
        rst,
        settings_overrides={"warning_stream": stream, "report_level": docutils.utils.Reporter.WARNING_LEVEL},
    )
    text = stream.getvalue()
    # Sphinx roles and directives are unknown to plain docutils; those are the site's to check.
    lines = [ln for ln in text.splitlines() if "ERROR" in ln or "WARNING" in ln]
    return [ln for ln in lines if "Unknown interpreted text role" not in ln and "Unknown directive" not in ln]


def test_public_definitions_have_parameters_and_returns():
    defs = public_definitions()
    incomplete = {q: m for q, o in sorted(defs.items()) if (m := missing_sections(o))}
    share = 1 - len(incomplete) / len(defs)
    listing = "\n".join(f"{q}: {', '.join(m)}" for q, m in incomplete.items())
    assert share >= MIN_SHARE, f"{share:.0%} of {len(defs)} public definitions complete; missing:\n{listing}"


def test_sections_render_without_warnings():
    bad = {q: p for q, o in sorted(public_definitions().items()) if (p := rst_problems(o))}
    assert not bad, "\n".join(f"{q}: {p[0]}" for q, p in bad.items())


def test_checker_finds_missing_sections():
    def documented(a_m: float) -> float:
        """Double it.

        Parameters
        ----------
        a_m : float
            A length (m).

        Returns
        -------
        float
            Twice ``a_m`` (m).
        """
        return 2 * a_m

    def undocumented(a_m: float) -> float:
        """Double it."""
        return 2 * a_m

    def side_effect(a_m: float) -> None:
        """Print it.

        Parameters
        ----------
        a_m : float
            A length (m).
        """

    assert missing_sections(documented) == []
    assert missing_sections(undocumented) == ["Parameters", "Returns"]
    assert missing_sections(side_effect) == []
