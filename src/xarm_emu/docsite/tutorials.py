"""The tutorials: one page per numbered example program of the repository's ``examples/``, its
docstring as the text and the whole file below it, so the page shows what the tests run."""

from __future__ import annotations

import ast
import re
from pathlib import Path

from .markdown import docstring

__all__ = ["examples", "home", "pages"]

_NUMBERED = re.compile(r"^(\d\d)_(\w+)\.py$")


def examples(directory: Path) -> list[Path]:
    """The numbered example programs (``01_connect_and_move.py``, ...), in order."""
    return sorted(p for p in directory.glob("*.py") if _NUMBERED.match(p.name))


def pages(directory: Path) -> list[tuple[str, str, str]]:
    out = []
    for path in examples(directory):
        m = _NUMBERED.match(path.name)
        assert m is not None
        source = path.read_text(encoding="utf-8")
        doc = ast.get_docstring(ast.parse(source)) or ""
        title = f"{int(m.group(1))}. " + m.group(2).replace("_", " ").capitalize()
        intro = (f"The program, `examples/{path.name}` (run it from the repository root: `python "
                 f"examples/{path.name}`; `tests/test_examples.py` runs every example):")
        text = "\n".join([f"# {title}", "", docstring(doc), intro, "",
                          f'```python title="examples/{path.name}"', source.rstrip(), "```", ""])
        out.append((f"tutorials/{path.stem}.md", title, text))
    return out


def home(readme: Path) -> tuple[str, str, str]:
    """The site's home page: the README's introduction, quick start and installation, as written
    there (the quick start is run verbatim by the tests), with its links made the site's."""
    text = readme.read_text(encoding="utf-8")
    end = text.find("\n## ", text.index("## Install"))
    part = text if end < 0 else text[:end + 1]
    part = re.sub(r"\]\(docs/([^)]+)\)", r"](\1)", part)
    part += ("\nNext: the [tutorials](tutorials/01_connect_and_move.md), the how-to guides, and the "
             "[reference](reference/index.md) generated from the emulator's own tables.\n")
    return "index.md", "Home", part
