"""Output that reads well at 80 columns and piped (a CI log): help without cut names or a type on
boolean flags, the Modbus map as a list, the start banner one clause a line."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import free_ports, port_args

NARROW = {**os.environ, "COLUMNS": "80"}


def _cli(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
    """``xarm-emu ARGS`` piped (stdout is not a terminal), 80 columns."""
    return subprocess.run([sys.executable, "-m", "xarm_emu.cli", *args], capture_output=True, text=True,
                          env=NARROW, timeout=timeout)


@pytest.mark.parametrize("command", [("serve",), ("status",), ("inject", "error"), ("set-input",), ("plot",)])
def test_help_fits_80_columns_with_whole_names(command: tuple[str, ...]) -> None:
    done = _cli(*command, "--help")
    assert done.returncode == 0
    lines = done.stdout.splitlines()
    assert all(len(line) <= 80 for line in lines), [line for line in lines if len(line) > 80]
    assert "…" not in done.stdout and "<bool>" not in done.stdout
    flat = " ".join(done.stdout.split())
    names = re.findall(r"env var: (XARM_EMU_[A-Z_]+)[;\]]", flat)  # each name whole, then ; or ]
    assert len(names) == flat.count("env var:")
    if command == ("serve",):
        assert "XARM_EMU_SERVE_DEVELOP_PORT" in names and "XARM_EMU_SERVE_ADMIN" in names


def test_modbus_map_is_a_list_at_80_columns() -> None:
    done = _cli("modbus-map")
    lines = done.stdout.splitlines()
    assert done.returncode == 0 and len(lines) > 50
    assert all(len(line) <= 80 for line in lines), [line for line in lines if len(line) > 80]
    assert "…" not in done.stdout
    assert "coil 142 reduced_mode r" in lines


def test_the_start_banner_is_one_clause_a_line(tmp_path: Path) -> None:
    cmd, normal, rich, develop = free_ports(4)
    argv = [sys.executable, "-m", "xarm_emu.cli", "serve", *port_args(cmd, normal, rich, develop),
            "--config-dir", str(tmp_path)]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=NARROW)
    try:
        assert proc.stdout is not None
        banner = [proc.stdout.readline() for _ in range(3)]
    finally:
        proc.terminate()
        proc.communicate(timeout=15)
    assert banner[0].startswith("xarm-emu ") and banner[0].rstrip().endswith("on 127.0.0.1")
    assert banner[1].strip() == f"ports: command {cmd}, normal {normal}, rich {rich}, develop {develop}"
    assert banner[2].strip() == f"speed x1; config {tmp_path}"
