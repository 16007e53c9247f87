"""Griffe extension of the API pages: the project's docstrings use reStructuredText's inline forms
(``:func:`name```, double backquotes, ``::`` before a literal block); this shows them as Markdown,
as xarm_emu.docsite does for the module docstrings it quotes."""

from __future__ import annotations

from typing import Any

import griffe

from xarm_emu.docsite.markdown import inline


class RestRoles(griffe.Extension):
    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            # "block::" introduces an indented block, which Markdown shows as code already
            lines = [line[:-1] if line.endswith("::") else line for line in obj.docstring.value.splitlines()]
            obj.docstring.value = "\n".join(inline(line) for line in lines)
