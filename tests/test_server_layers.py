"""The server package is a DAG under everything that composes it: no module of server/ imports the
viewer, the CLI or the testing helpers, and admin requests and fault schedules never import the
server they act on (they work on the AdminTarget protocol)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SERVER = Path(__file__).resolve().parents[1] / "src" / "xarm_emu" / "server"


def imported(path: Path) -> set[str]:
    """Every module ``path`` imports (relative names resolved inside xarm_emu), TYPE_CHECKING ones too."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = ["xarm_emu", "server"][: max(0, 2 - node.level + 1)] if node.level else []
            module = ".".join([*base, *(node.module.split(".") if node.module else [])])
            names.add(module)
            names.update(f"{module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
    return names


@pytest.mark.parametrize("path", sorted(SERVER.glob("*.py")), ids=lambda p: p.name)
def test_server_imports_nothing_above_it(path: Path) -> None:
    above = ("xarm_emu.viewer", "xarm_emu.cli", "xarm_emu.testing", "xarm_emu.client")
    assert not [m for m in imported(path) if m.startswith(above)]


@pytest.mark.parametrize("name", ["admin.py", "faults.py", "admin_port.py", "command_port.py",
                                  "report_ports.py"])
def test_requests_and_ports_do_not_import_the_server(name: str) -> None:
    server = ("xarm_emu.server.app", "xarm_emu.server.core", "xarm_emu.server.thread")
    assert not [m for m in imported(SERVER / name) if m.startswith(server)]
