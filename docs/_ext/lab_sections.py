"""One title per page on the documentation site: later top-level headings go under the first.

A page whose source has a second top-level heading, as chapter 04 has ("# Part 2 — the real
(emulated as-built) robot"), would show that heading in the site's sidebar as an entry of the
course of its own, beside the chapters: Sphinx lists every top-level section of a page in a
table of contents, and ``:titlesonly:`` (or Furo's ``titles_only``) keeps them all. The
notebook reads right in JupyterLab and on GitHub as it is, so the site changes, not the
notebook: before the page's table of contents is collected, every top-level section after
the first becomes the last subsection of the first. The page keeps its anchors
(``#part-2-the-real-emulated-as-built-robot`` still works); the later part's headings show
one level lower, under the page's title, as the parts of one page.
"""

from __future__ import annotations

from docutils import nodes
from sphinx.transforms import SphinxTransform


class OneTitlePerPage(SphinxTransform):
    """Move every top-level section after the first into the first (in order, at its end)."""

    # after the parser built the sections, before doctree-read collects titles and tocs (880)
    default_priority = 500

    def apply(self, **kwargs) -> None:
        tops = [node for node in self.document.children if isinstance(node, nodes.section)]
        for later in tops[1:]:
            self.document.remove(later)
            tops[0].append(later)


def setup(app):
    app.add_transform(OneTitlePerPage)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
