"""The readiness probe of containers and pods (``python -m xarm_emu.client.ready``): exit 0 once the
box answers a version request on its command port, 1 when it never does, 2 for a usage mistake;
it loads the client and the protocol tables alone."""

from __future__ import annotations

import socket
import subprocess
import sys

from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerConfig, ServerThread


def _probe(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "xarm_emu.client.ready", *args], capture_output=True,
                          text=True, timeout=60)


def test_exit_0_once_the_box_answers() -> None:
    config = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0)
    with ServerThread(Emulator(6), config) as st:
        done = _probe("--port", str(st.ports["command"]), "--wait", "5")
    assert done.returncode == 0, done.stderr
    assert done.stdout == "" and done.stderr == ""


def test_exit_1_naming_the_address_when_nothing_answers() -> None:
    with socket.socket() as s:  # a port that was free a moment ago: nothing listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    done = _probe("--port", str(port), "--wait", "0.3")
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        f"the control box at 127.0.0.1:{port} does not answer: [Errno 111] Connection refused"]


def test_an_open_port_that_does_not_speak_the_protocol_is_not_ready() -> None:
    with socket.socket() as srv:
        srv.bind(("127.0.0.1", 0))
        srv.listen()
        done = _probe("--port", str(srv.getsockname()[1]), "--wait", "0.3")
    assert done.returncode == 1 and "does not answer" in done.stderr


def test_usage_mistakes_exit_2() -> None:
    assert _probe("--port", "0").returncode == 2
    assert _probe("--wait", "soon").returncode == 2


def test_it_loads_the_client_alone() -> None:
    code = ("import sys, xarm_emu.client.ready; "
            "print(sorted({m.split('.')[1] for m in sys.modules if m.startswith('xarm_emu.')}), "
            "'numpy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "['_version', 'client', 'protocol'] False"  # _version: the package's number
