"""One exit-code policy for every command: 2 for a usage or input mistake (an argument the command
or the admin channel refuses), 1 for a runtime failure (a port in use, the box or the admin
channel unreachable), each with one line on stderr that says what to do next; never a traceback."""

from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

from helpers import free_ports, port_args, run_cli

from xarm_emu.testing import running_emulator

REFUSED_ARGUMENTS = [("inject", "report-pause", "2x"), ("inject", "error", "C999"),
                     ("set-input", "cgpio", "99", "1"), ("inject", "servo-error", "S23", "--joint", "9")]


def test_an_argument_the_admin_channel_refuses_is_exit_2_in_one_line() -> None:
    with running_emulator(admin=True) as st:
        where = ("--port", str(st.ports["command"]), "--admin-port", str(st.ports["admin"]))
        for args in REFUSED_ARGUMENTS:
            code, out = run_cli(*args, *where)
            assert code == 2, (args, out)
            assert len(out.strip().splitlines()) == 1 and out.startswith("refused: "), (args, out)
        assert st.call(lambda: st.emulator.controller.error_code) == 0  # nothing was injected
        code, out = run_cli("inject", "error", "C31", *where)  # the same command, a good argument
        assert code == 0 and out.startswith("injected C31")


def test_no_admin_channel_is_a_runtime_failure_exit_1() -> None:
    (port,) = free_ports(1)
    code, out = run_cli("inject", "estop", "--port", str(port), "--admin-port", str(port))
    assert code == 1
    assert len(out.strip().splitlines()) == 1 and "xarm-emu serve --admin" in out


def test_a_port_in_use_is_exit_1_naming_the_port_and_the_way_out(tmp_path: Path) -> None:
    cmd, normal, rich, develop = free_ports(4)
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", cmd))
        taken.listen()
        done = subprocess.run([sys.executable, "-m", "xarm_emu.cli", "serve", *port_args(cmd, normal, rich,
                                                                                         develop),
                               "--config-dir", str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 1
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert f"127.0.0.1:{cmd}" in lines[0] and "already in use" in lines[0]
    assert "--host 127.0.0.N" in lines[0] and "--port" in lines[0]


def test_the_help_states_the_policy() -> None:
    code, out = run_cli("--help")
    flat = " ".join(out.replace("│", " ").split())
    assert code == 0
    assert "Exit status: 0 done; 2 a usage or input mistake" in flat and "1 a runtime failure" in flat
