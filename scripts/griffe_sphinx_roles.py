"""A griffe extension for the API pages: Sphinx roles in docstrings become inline code.

emorbit's docstrings name other objects as Sphinx does (``:class:`Simulation```,
``:func:`~emorbit.orbits.propagate```); mkdocstrings would print the role literally. This
extension, named in mkdocs.yml, rewrites each role as inline code of the name it shows
(the last component after ``~``), before the docstring is parsed.
"""

from __future__ import annotations

import re

import griffe

ROLE = re.compile(r":(?:py:)?(?:func|meth|class|data|attr|mod|obj|exc|const|ref):`(~?)([^`<]+?)(?:\s*<[^>]*>)?`")


def plain(text: str) -> str:
    """``text`` with every Sphinx role replaced by inline code."""
    return ROLE.sub(lambda m: f"`{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}`", text)


class SphinxRoles(griffe.Extension):
    """Rewrite the Sphinx roles of every docstring griffe loads."""

    def on_instance(self, *, obj: griffe.Object, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = plain(obj.docstring.value)
