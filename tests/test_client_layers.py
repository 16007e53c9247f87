"""The client speaks the wire and nothing else: a program that only talks to a real box loads the
protocol layer, never the emulator (controller, model, server) or the viewer."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

CLIENT = Path(__file__).resolve().parents[1] / "src" / "xarm_emu" / "client"
ALLOWED = ("xarm_emu.protocol", "xarm_emu.client")


def imported(source: str, package: str = "xarm_emu.client") -> set[str]:
    """Every module ``source`` imports, at any depth (inside functions and ``TYPE_CHECKING`` blocks
    too), relative names resolved against ``package``."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            parts = package.split(".")
            base = parts[: len(parts) - node.level + 1] if node.level else []
            names.add(".".join([*base, *(node.module.split(".") if node.module else [])]))
        elif isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
    return names


def test_the_walker_sees_imports_inside_functions_and_type_checking() -> None:
    source = ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..server import app\n"
              "def f():\n    from ..controller.config import x\n    import xarm_emu.viewer\n")
    assert {"xarm_emu.server", "xarm_emu.controller.config", "xarm_emu.viewer"} <= imported(source)


@pytest.mark.parametrize("path", sorted(CLIENT.glob("*.py")), ids=lambda p: p.name)
def test_client_imports_only_the_protocol(path: Path) -> None:
    ours = {m for m in imported(path.read_text()) if m == "xarm_emu" or m.startswith("xarm_emu.")}
    assert ours, "every client module imports from the package"
    assert not [m for m in ours if not m.startswith(ALLOWED)]


def test_importing_the_client_loads_no_emulator_module() -> None:
    code = ("import sys, xarm_emu.client, xarm_emu.client.admin\n"
            "print(','.join(sorted(m for m in sys.modules if m.startswith('xarm_emu.'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         timeout=60).stdout.strip().split(",")
    assert "xarm_emu.client.admin" in out and "xarm_emu.protocol.admin_token" in out
    assert not [m for m in out if m.startswith(("xarm_emu.controller", "xarm_emu.server",
                                                 "xarm_emu.model", "xarm_emu.viewer"))]
