"""Small Markdown helpers of the generated pages: table cells, tables and docstrings."""

from __future__ import annotations

import html
import re
from collections.abc import Iterable, Sequence

__all__ = ["cell", "code", "docstring", "inline", "table"]


def cell(text: object) -> str:
    """``text`` as a table cell: HTML escaped (``<axis>`` stays visible), pipes and line breaks
    neutralised."""
    return html.escape(str(text), quote=False).replace("|", "&#124;").replace("\n", " ")


def code(text: object) -> str:
    """``text`` as inline code inside a table cell (a pipe cannot be escaped inside a code span, so it
    becomes a literal HTML code element)."""
    s = str(text)
    if "|" in s or "`" in s:
        return f"<code>{cell(s)}</code>"
    return f"`{s}`" if s else ""


def table(header: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    """A Markdown table; cells are given already formatted (see :func:`cell`)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


_ROLE = re.compile(r":(?:mod|func|class|data|meth|attr|obj):`~?([^`]+)`")


def docstring(text: str | None) -> str:
    """A module docstring (reStructuredText as the project writes it) as Markdown: ````x```` becomes
    ```x```, cross-reference roles their target's name, a paragraph ending in ``::`` introduces the
    indented block after it as a code block."""
    if not text:
        return ""
    lines = text.strip("\n").splitlines()
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        out.append(inline(line[:-1] if line.rstrip().endswith("::") else line))
        if line.rstrip().endswith("::"):
            if line.rstrip() != "::":
                out[-1] = out[-1].rstrip()  # "tables::" -> "tables:"
            block: list[str] = []
            i += 1
            while i < len(lines) and (not lines[i].strip() or lines[i].startswith(" ")):
                block.append(lines[i])
                i += 1
            while block and not block[-1].strip():
                block.pop()
            indent = min((len(b) - len(b.lstrip()) for b in block if b.strip()), default=0)
            out += ["", "```toml" if any("=" in b for b in block) else "```"]
            out += [b[indent:] for b in block if b.strip() or b == ""]
            out += ["```", ""]
            continue
        i += 1
    return "\n".join(out) + "\n"


def inline(line: str) -> str:
    """One line of reStructuredText inline markup as Markdown: roles as their target's name in code,
    double backquotes as single ones."""
    line = _ROLE.sub(lambda m: "`" + m.group(1).lstrip(".").rsplit(".", 1)[-1] + "`", line)
    return line.replace("``", "`")
