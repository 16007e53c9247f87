"""The ``xarm-emu`` CLI against a ServerThread, through typer's
CliRunner: status, inject, clear, set-input, and serve's messages for privileged or busy ports."""

from __future__ import annotations

import errno
import json
import math
import socket
import time
from pathlib import Path

import pytest
from helpers import free_ports, port_args, serve_subprocess
from helpers import run_cli as run

from xarm_emu import cli
from xarm_emu.server.app import ServerThread


def addr(st: ServerThread) -> list[str]:
    return ["--port", str(st.ports["command"]), "--admin-port", str(st.ports["admin"])]


def state_of(st: ServerThread) -> tuple[int, int, list[int]]:
    def read() -> tuple[int, int, list[int]]:
        c = st.emulator.controller
        return c.error_code, c.warning_code, list(c.servo_errors)
    return st.call(read)  # type: ignore[return-value]


def test_status_json(server: ServerThread) -> None:
    code, out = run("status", "--json", "--port", str(server.ports["command"]),
                    "--report-port", str(server.ports["develop"]))
    assert code == 0, out
    data = json.loads(out)
    assert data["version"] == server.call(lambda: server.emulator.controller.version_string())
    assert (data["state"], data["mode"], data["error"], data["warning"]) == (4, 0, 0, 0)
    assert data["joints"] == [0.0] * 6
    assert data["pose"][:3] == pytest.approx([207.0, 0.0, 112.0], abs=1e-3)
    assert abs(abs(data["pose"][3]) - math.pi) < 1e-5


def test_status_table_and_unreachable(server: ServerThread) -> None:
    code, out = run("status", "--port", str(server.ports["command"]), "--report-port",
                    str(server.ports["develop"]))
    assert code == 0 and "stop" in out and "207.000" in out
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        free = s.getsockname()[1]
    code, out = run("status", "--port", str(free))
    assert code == 1 and "cannot reach the control box" in out


@pytest.mark.parametrize("args, expect", [
    (["inject", "estop"], (1, 0)),
    (["inject", "error", "C31"], (31, 0)),
    (["inject", "warning", "11"], (0, 11)),
    (["inject", "end-module-lost"], (28, 0)),
    (["inject", "servo-error", "--joint", "3", "S23"], (13, 0)),
    (["inject", "collision", "--joint", "2", "--torque", "-40"], (31, 0)),  # default sensitivity 3
])
def test_inject_then_clear(server: ServerThread, args: list[str], expect: tuple[int, int]) -> None:
    code, out = run(*args, *addr(server))
    assert code == 0, out
    assert state_of(server)[:2] == expect
    code, out = run("clear", *addr(server))
    assert code == 0 and "cleared" in out
    assert state_of(server) == (0, 0, [0] * 6)


def test_inject_gripper_delay_pause_and_inputs(server: ServerThread) -> None:
    assert run("inject", "gripper-error", "G11", *addr(server))[0] == 0
    assert server.call(lambda: server.emulator.gripper.gripper.error) == 11
    code, out = run("inject", "reply-delay", "50ms", *addr(server))
    assert code == 0 and "50 ms" in out
    assert server.call(lambda: server.server.reply_delay) == pytest.approx(0.05)
    code, out = run("inject", "report-pause", "2s", *addr(server))
    assert code == 0 and server.call(server.server.reports_paused) is True
    assert run("inject", "drop-clients", *addr(server))[0] == 0
    assert run("set-input", "cgpio", "3", "1", *addr(server))[0] == 0
    assert run("set-input", "tgpio", "0", "1", *addr(server))[0] == 0
    assert run("set-input", "analog", "1", "5.0", *addr(server))[0] == 0
    assert server.call(lambda: server.emulator.io.tool.digital_inputs & 1) == 1
    assert run("clear", *addr(server))[0] == 0
    assert server.call(lambda: (server.server.reply_delay, server.server.reports_paused())) == (0.0, False)


@pytest.mark.parametrize("args, fragment", [
    (["inject", "error", "C99"], "not in the manual"),
    (["inject", "error", "nonsense"], "not an error label"),
    (["inject", "servo-error", "--joint", "9", "S23"], "joint 9 out of range 1..6"),
    (["inject", "warning", "C31"], "not a warning"),
    (["inject", "reply-delay", "soon"], "not a duration"),
    (["set-input", "cgpio", "40", "1"], "cgpio input 40"),
])
def test_cli_refusals_change_nothing(server: ServerThread, args: list[str], fragment: str) -> None:
    before = state_of(server)
    code, out = run(*args, *addr(server))
    assert code == 2  # an argument the emulator refuses: a usage mistake
    assert "refused" in out and fragment in " ".join(out.split())
    assert state_of(server) == before


def test_inject_derives_the_admin_port_from_the_command_port(server_with_derived_admin_port) -> None:
    st = server_with_derived_admin_port
    code, out = run("inject", "error", "C31", "--port", str(st.ports["command"]))
    assert code == 0, out
    assert state_of(st)[0] == 31


def test_inject_without_admin_channel(make_server) -> None:
    st = make_server()  # no --admin
    code, out = run("inject", "estop", "--port", str(st.ports["command"]), "--admin-port",
                    str(st.ports["command"] + 1 if st.ports["command"] < 65535 else 1))
    assert code == 1 and "serve --admin" in " ".join(out.split())
    assert state_of(st)[0] == 0


def test_serve_privileged_port_message(monkeypatch: pytest.MonkeyPatch, tmp_path) -> None:
    def refuse(coro, loop) -> None:
        coro.close()
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(cli, "_run", refuse)
    code, out = run("serve", "--config-dir", str(tmp_path))
    assert code == 1
    text = " ".join(out.split())
    assert "cannot bind port 502" in text and "--port 5020" in text and "TCP_CONTROL_PORT" in text


def test_serve_port_in_use_message(monkeypatch: pytest.MonkeyPatch, tmp_path) -> None:
    def busy(coro, loop) -> None:
        coro.close()
        raise OSError(errno.EADDRINUSE, "Address already in use")

    monkeypatch.setattr(cli, "_run", busy)
    code, out = run("serve", "--port", "5020", "--config-dir", str(tmp_path))
    assert code == 1 and "already in use" in out


def test_serve_rejects_bad_speed(tmp_path) -> None:
    code, out = run("serve", "--speed", "0", "--config-dir", str(tmp_path))
    assert code == 2 and "--speed" in out


def test_status_wait_is_a_readiness_probe(tmp_path: Path) -> None:
    """`serve &` then `status --wait`: returns once the protocol answers, not before; exit 1 if never."""
    (free,) = free_ports(1)
    t0 = time.monotonic()
    code, out = run("status", "--port", str(free), "--wait", "0.5")
    assert code == 1 and "cannot reach the control box" in out and time.monotonic() - t0 >= 0.5
    cmd, normal, rich, develop = free_ports(4)
    with serve_subprocess(tmp_path, *port_args(cmd, normal, rich, develop)):
        code, out = run("status", "--json", "--wait", "30", "--port", str(cmd), "--report-port", str(develop))
        assert code == 0, out
        assert json.loads(out)["version"].startswith("6,6,")


def test_serve_subprocess_with_admin(tmp_path: Path) -> None:
    """`xarm-emu serve --admin` end to end: the banner names the admin port; inject reaches it."""
    cmd, normal, rich, develop, admin = free_ports(5)
    admin_args = ("--admin", "--admin-port", str(admin))
    with serve_subprocess(tmp_path, *port_args(cmd, normal, rich, develop), *admin_args) as proc:
        assert proc.stdout is not None
        banner = "".join(proc.stdout.readline() for _ in range(4))
        assert f"admin channel (fault injection) on 127.0.0.1:{admin}" in " ".join(banner.split()), banner
        code, out = run("inject", "error", "C31", "--port", str(cmd), "--admin-port", str(admin))
        assert code == 0, out
        code, out = run("status", "--json", "--port", str(cmd), "--report-port", str(develop))
        assert code == 0 and json.loads(out)["error"] == 31
