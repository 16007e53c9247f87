"""The command line's reference page: every command, its usage, arguments and options, written at
build time from the click commands typer builds for ``xarm-emu`` (typer's own Markdown writer, the
one behind ``typer ... utils docs``), so an option added to a command appears without editing a page.

mkdocs-click cannot read these commands: typer 0.29 builds them on its own copy of click, and
mkdocs-click recognises options by ``isinstance(param, click.Option)``, so it would list the commands
without a single option.
"""

from __future__ import annotations

from typing import Any

import typer
from typer.cli import get_docs_for_click

from ..cli import app

__all__ = ["command", "command_names", "markdown", "page"]

#: The click command of ``xarm-emu``.
command: Any = typer.main.get_command(app)


def command_names(cmd: Any = command, prefix: str = "xarm-emu") -> list[str]:
    """Every command as it is typed (``xarm-emu serve``, ``xarm-emu inject estop``, ...), groups
    before their commands."""
    out = [prefix]
    for name, sub in getattr(cmd, "commands", {}).items():
        if not sub.hidden:
            out += command_names(sub, f"{prefix} {name}")
    return out


def markdown() -> str:
    """The commands as Markdown: ``xarm-emu`` a second-level heading, each command one level below
    its group."""
    ctx = typer.Context(command, info_name="xarm-emu")
    return get_docs_for_click(obj=command, ctx=ctx, indent=1, name="xarm-emu")


def page() -> tuple[str, str, str]:
    text = "\n".join([
        "# Command line", "",
        "Every `xarm-emu` command with its arguments and options, written from the command line's own "
        "definition when this site was built. Every option can also be given as an environment variable "
        "`XARM_EMU_<COMMAND>_<OPTION>` (for example `XARM_EMU_SERVE_PORT=5020`). Exit status: 0 done, 2 a "
        "usage or input mistake, 1 a runtime failure, with one line on stderr saying what to do next.", "",
        markdown(),
    ])
    return "reference/cli.md", "Command line", text
