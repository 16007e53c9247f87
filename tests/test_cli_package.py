"""The command line stands in small rooms: one module per group of commands, none over 400 lines and
no function over 80, and the ``xarm-emu`` entry point and ``python -m xarm_emu.cli`` both reach it."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

CLI = Path(__file__).resolve().parents[1] / "src" / "xarm_emu" / "cli"


def function_lengths(source: str) -> dict[str, int]:
    """Lines of every function (decorators included), nested ones too."""
    out = {}
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            start = min([node.lineno, *(d.lineno for d in node.decorator_list)])
            out[f"{node.name}:{node.lineno}"] = (node.end_lineno or node.lineno) - start + 1
    return out


def test_the_measure_counts_decorators_and_bodies() -> None:
    source = "@app.command()\ndef f(\n    a: int,\n) -> None:\n    x = 1\n    return None\n"
    assert function_lengths(source) == {"f:2": 6}


@pytest.mark.parametrize("path", sorted(CLI.glob("*.py")), ids=lambda p: p.name)
def test_modules_and_functions_stay_small(path: Path) -> None:
    source = path.read_text(encoding="utf-8")
    assert len(source.splitlines()) <= 400
    assert {name: n for name, n in function_lengths(source).items() if n > 80} == {}


def test_python_m_reaches_the_same_commands() -> None:
    done = subprocess.run([sys.executable, "-m", "xarm_emu.cli", "version"], capture_output=True,
                          text=True, timeout=60)
    from xarm_emu import __version__

    assert (done.returncode, done.stdout.strip(), done.stderr) == (0, __version__, "")
