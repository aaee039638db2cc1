"""A griffe extension for the API pages: Sphinx roles in docstrings become inline code, and
RST literal blocks fenced code.

emorbit's docstrings name other objects as Sphinx does (``:class:`Simulation```,
``:func:`~emorbit.orbits.propagate```); mkdocstrings would print the role literally. This
extension, named in mkdocs.yml, rewrites each role as inline code of the name it shows
(the last component after ``~``), before the docstring is parsed. A paragraph that ends in
``::`` introduces an RST literal block (the lines indented below it); Markdown would print
the ``::`` and run the block into a paragraph, so the block becomes a fenced code block and
the ``::`` a colon (nothing, where it stands alone or after a space).
"""

from __future__ import annotations

import re
import textwrap

import griffe

ROLE = re.compile(r":(?:py:)?(?:func|meth|class|data|attr|mod|obj|exc|const|ref):`(~?)([^`<]+?)(?:\s*<[^>]*>)?`")


def plain(text: str) -> str:
    """``text`` with every Sphinx role replaced by inline code."""
    return ROLE.sub(lambda m: f"`{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}`", text)


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def literal_blocks(text: str) -> str:
    """``text`` with every RST literal block (``::`` and the indented lines below it) as a
    fenced code block."""
    lines, out, i = text.split("\n"), [], 0
    while i < len(lines):
        line = lines[i]
        j = i + 1
        while j < len(lines) and not lines[j].strip():
            j += 1
        k = j
        while k < len(lines) and (not lines[k].strip() or _indent(lines[k]) > _indent(line)):
            k += 1
        if not line.rstrip().endswith("::") or k == j:
            out.append(line)
            i += 1
            continue
        head = line.rstrip()[:-2]
        if head.strip():
            out += [head.rstrip() + ("" if head.endswith(" ") else ":"), ""]
        block = textwrap.dedent("\n".join(lines[j:k])).strip("\n").split("\n")
        pad = " " * _indent(line)
        out += [pad + "```", *(pad + b if b.strip() else "" for b in block), pad + "```", ""]
        i = k
    return "\n".join(out)


class SphinxRoles(griffe.Extension):
    """Rewrite the Sphinx roles of every docstring griffe loads."""

    def on_instance(self, *, obj: griffe.Object, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = literal_blocks(plain(obj.docstring.value))
