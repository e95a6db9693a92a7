"""MathJax for the documentation site, offline: the few files it needs, copied from a package.

Sphinx's ``sphinx.ext.mathjax`` loads MathJax from a CDN, so on a site opened from
``file://`` with no network every formula stayed raw TeX (``\\(y(u)\\)``). The pinned
package ``django-static-mathjax`` (environment.txt; it ships MathJax 3.2.2's files and needs
no Django) holds all of MathJax, about 35 MB; the site takes only what it uses: the combined
component ``tex-chtml-full.js`` (the loader, the TeX input with every extension, so nothing
is ever fetched on demand, and the CommonHTML output) and that output's woff fonts, about
1.7 MB in all. They are copied into ``_static/mathjax/`` after a successful build, in the
layout MathJax expects (it finds its fonts beside the script), and are never committed.

docs/conf.py points ``mathjax_path`` at the copy (``MATHJAX_PATH``). Why this package:
docs/site.md.
"""

from __future__ import annotations

import importlib.metadata
import shutil
from pathlib import Path

from sphinx.errors import ExtensionError

#: The pinned package that ships MathJax's files, and MathJax's folder inside it.
PACKAGE = "django-static-mathjax"
PACKAGE_DIR = "mathjax/static/mathjax/es5"
#: The combined component the pages load, relative to the site's _static/.
MATHJAX_PATH = "mathjax/tex-chtml-full.js"
#: The CommonHTML output's fonts, relative to MathJax's folder (its default ``fontURL``).
FONTS_DIR = "output/chtml/fonts/woff-v2"


def source_dir() -> Path:
    """MathJax's ``es5`` folder in the installed package; ExtensionError if it is missing."""
    try:
        dist = importlib.metadata.distribution(PACKAGE)
    except importlib.metadata.PackageNotFoundError:
        raise ExtensionError(
            f"the site's math needs the package {PACKAGE} (pinned in environment.txt): "
            "run scripts/docs, which installs environment.txt into .venv"
        ) from None
    folder = Path(dist.locate_file(PACKAGE_DIR))
    if not (folder / Path(MATHJAX_PATH).name).is_file() or not (folder / FONTS_DIR).is_dir():
        raise ExtensionError(f"{folder}: not MathJax's es5 folder (reinstall {PACKAGE})")
    return folder


def files_to_copy() -> list[tuple[Path, str]]:
    """(source file, path relative to the site's _static/) of every file the site needs."""
    folder = source_dir()
    target = Path(MATHJAX_PATH).parent
    files = [(folder / Path(MATHJAX_PATH).name, MATHJAX_PATH)]
    files += [(p, (target / FONTS_DIR / p.name).as_posix()) for p in sorted((folder / FONTS_DIR).glob("*.woff"))]
    return files


def _check(app) -> None:
    if app.builder.format == "html":
        source_dir()  # fail before reading any page, not after the whole build


def _copy(app, exception) -> None:
    if exception is not None or app.builder.format != "html":
        return
    static = Path(app.outdir) / "_static"
    for source, relative in files_to_copy():
        target = static / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(source, target)


def setup(app):
    app.connect("builder-inited", _check)
    app.connect("build-finished", _copy)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
