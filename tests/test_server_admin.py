"""Admin channel: off by default, loopback only, JSON lines; each injected fault shows
on the command port as the natural one would; bad input is refused and changes nothing."""

from __future__ import annotations

import asyncio
import json
import socket
import time
from typing import Any

import pytest

from xarm_emu.client import Client
from xarm_emu.client.admin import AdminClient, AdminRefused, admin_port
from xarm_emu.protocol.admin import derive_admin_port, is_loopback
from xarm_emu.server.admin import parse_duration
from xarm_emu.server.admin_port import AdminProtocol
from xarm_emu.server.app import ServerConfig, ServerThread


@pytest.fixture
def srv(server: ServerThread) -> ServerThread:
    return server


@pytest.fixture
def admin(srv: ServerThread):
    with AdminClient("127.0.0.1", srv.ports["admin"]) as a:
        yield a


def fault_state(srv: ServerThread) -> dict[str, Any]:
    def read() -> dict[str, Any]:
        emu = srv.emulator
        ctl = emu.controller
        return {"error": ctl.error_code, "warning": ctl.warning_code, "servo": list(ctl.servo_errors),
                "gripper": emu.gripper.gripper.error, "state": ctl.state, "delay": srv.server.reply_delay,
                "pause": srv.server.report_pause_until, "cgpio": emu.io.cgpio.digital_inputs,
                "tgpio": emu.io.tool.digital_inputs, "clients": len(srv.server.command_clients)}
    return srv.call(read)  # type: ignore[return-value]


def test_admin_is_off_by_default(make_server) -> None:
    st = make_server()
    assert "admin" not in st.ports
    assert ServerConfig().admin is False


def test_admin_binds_loopback_even_when_host_is_any(make_server) -> None:
    st = make_server(host="0.0.0.0", admin=True)
    bound = st.call(lambda: [s.sockets[0].getsockname() for s in st.server._servers])
    admin_addr = [a for a in bound if a[1] == st.ports["admin"]]
    assert admin_addr and admin_addr[0][0] == "127.0.0.1"


def test_admin_binds_the_arms_own_loopback_address(make_server) -> None:
    """Arms on 127.0.0.2, 127.0.0.3, ... each have their admin channel on their own address."""
    try:
        with socket.socket() as s:
            s.bind(("127.0.0.2", 0))
    except OSError:
        pytest.skip("this system routes only 127.0.0.1: run on Linux, which routes all of 127.0.0.0/8")
    st = make_server(host="127.0.0.2", admin=True)
    bound = st.call(lambda: [s.sockets[0].getsockname() for s in st.server._servers])
    assert ("127.0.0.2", st.ports["admin"]) in [tuple(a[:2]) for a in bound]
    with AdminClient("127.0.0.2", st.ports["admin"]) as a:
        assert "C31" in a.request("error", code="C31")


def test_admin_port_derivation() -> None:
    assert derive_admin_port(502) == 10502
    assert admin_port(5020) == 15020
    assert admin_port(5020, 7000) == 7000
    with pytest.raises(ValueError, match="admin-port"):
        derive_admin_port(60000)


def test_derived_admin_port_is_used_by_the_server(server_with_derived_admin_port) -> None:
    st = server_with_derived_admin_port
    p = st.ports["command"]
    assert st.ports["admin"] == p + 10000
    with AdminClient("127.0.0.1", admin_port(p)) as a:
        assert "C1" in a.request("estop")


def test_error_and_estop_show_on_the_command_port(srv: ServerThread, admin: AdminClient) -> None:
    with Client("127.0.0.1", srv.ports["command"]) as c:
        c.motion_enable(True), c.set_mode(0), c.set_state(0)
        assert "C31" in admin.request("error", code="C31")
        r = c.call(15)
        assert r.has_error and (r["error"], r["warning"]) == (31, 0)
        assert c.get_state() == 4
        assert "cleared" in admin.request("clear")
        assert c.get_err_warn() == (0, 0)
        admin.request("estop")
        assert c.get_err_warn() == (1, 0)
        admin.request("end-module-lost")
        assert c.get_err_warn()[0] == 28
        admin.request("error", code=31)  # a bare number is a C code
        assert c.get_err_warn()[0] == 31
        # natural recovery (manual 3.3): clean error, enable, state 0
        c.clean_error(), c.motion_enable(True), c.set_mode(0), c.set_state(0)
        assert c.get_err_warn() == (0, 0) and c.get_state() == 2


def test_warning_only_sets_the_warning_bit(srv: ServerThread, admin: AdminClient) -> None:
    with Client("127.0.0.1", srv.ports["command"]) as c:
        c.motion_enable(True), c.set_mode(0), c.set_state(0)
        admin.request("warning", code="11")
        r = c.call(13)
        assert r.has_warning and not r.has_error and r["state"] == 2
        assert c.get_err_warn() == (0, 11)
        admin.request("warning", code="W12")
        assert c.get_err_warn() == (0, 12)


def test_servo_error_on_joint_3(srv: ServerThread, admin: AdminClient) -> None:
    with Client("127.0.0.1", srv.ports["command"]) as c:
        assert "joint 3" in admin.request("servo-error", joint=3, code="S23")
        assert c.get_err_warn()[0] == 13  # C10 + joint
        r = c.call(106)  # servo error codes per joint (manual 2.1.4)
        assert r.raw and not r.has_warning
    assert srv.call(lambda: list(srv.emulator.controller.servo_errors)) == [0, 0, 23, 0, 0, 0]


def test_collision_is_c31_only_when_the_sensitivity_detects_it(srv: ServerThread, admin: AdminClient) -> None:
    with Client("127.0.0.1", srv.ports["command"]) as c:
        c.call(11, joint=8, enable=1)
        c.call(37, sensitivity=0)  # detection off
        assert "not detected" in admin.request("collision", joint=2, torque=100.0)
        assert c.get_err_warn()[0] == 0
        c.call(37, sensitivity=3)
        assert "not detected" in admin.request("collision", joint=2, torque=-25.0)
        assert c.get_err_warn()[0] == 0
        assert "C31" in admin.request("collision", joint=2, torque=-30.0)
        assert c.get_err_warn()[0] == 31
        assert c.call(13).state & 0x40


def test_gripper_error(srv: ServerThread, admin: AdminClient) -> None:
    admin.request("gripper-error", code="G11")
    assert srv.call(lambda: srv.emulator.gripper.gripper.error) == 11


def test_reply_delay(srv: ServerThread, admin: AdminClient) -> None:
    with Client("127.0.0.1", srv.ports["command"]) as c:
        t0 = time.perf_counter()
        c.get_state()
        base = time.perf_counter() - t0
        assert admin.request("reply-delay", seconds="50ms") == "reply delay 50 ms"
        t0 = time.perf_counter()
        for _ in range(3):
            c.get_state()
        per_call = (time.perf_counter() - t0) / 3
        assert 0.045 <= per_call <= 0.1
        admin.request("reply-delay", seconds=0)
        t0 = time.perf_counter()
        c.get_state()
        assert time.perf_counter() - t0 < max(0.02, 5 * base)


def test_report_pause(srv: ServerThread, admin: AdminClient) -> None:
    with socket.create_connection(("127.0.0.1", srv.ports["develop"]), timeout=2) as dev:
        assert len(dev.recv(87, socket.MSG_WAITALL)) == 87
        admin.request("report-pause", seconds="0.5s")
        time.sleep(0.03)
        dev.settimeout(0.05)
        with pytest.raises(TimeoutError):  # drain what was in flight, then silence
            while True:
                dev.recv(65536)
        t0 = time.monotonic()
        dev.settimeout(2)
        dev.recv(1)
        waited = time.monotonic() - t0
        assert 0.3 <= waited <= 0.7


def test_drop_clients(srv: ServerThread, admin: AdminClient) -> None:
    c = Client("127.0.0.1", srv.ports["command"])
    rep = socket.create_connection(("127.0.0.1", srv.ports["normal"]), timeout=2)
    try:
        c.get_state()
        time.sleep(0.05)
        assert admin.request("drop-clients") == "dropped 2 client connections"
        c._sock.settimeout(2)
        assert c._sock.recv(10) == b""
        rep.settimeout(2)
        while rep.recv(4096):
            pass
        # the admin connection itself stays, and new clients are welcome
        assert "status" not in admin.request("status")
        with Client("127.0.0.1", srv.ports["command"]) as c2:
            assert c2.get_state() == 4
    finally:
        c.close()
        rep.close()


def test_set_input(srv: ServerThread, admin: AdminClient) -> None:
    with Client("127.0.0.1", srv.ports["command"]) as c:
        admin.request("set-input", kind="cgpio", index=3, value=1)
        on = c.call(131)["digital"]  # CGPIO_GET_DIGIT (manual 2.1.4)
        admin.request("set-input", kind="cgpio", index=3, value=0)
        off = c.call(131)["digital"]
        assert on ^ off == 1 << 3
        admin.request("set-input", kind="analog", index=1, value=5.0)
        assert c.call(133)["analog"] == pytest.approx(2048, abs=1)  # 5 V of a 10 V, 12-bit input
    admin.request("set-input", kind="tgpio", index=0, value=1)
    assert fault_state(srv)["tgpio"] & 1


@pytest.mark.parametrize("request_, fragment", [
    ({"cmd": "explode"}, "unknown command"),
    ({"cmd": "error", "code": "C99"}, "not in the manual"),
    ({"cmd": "error", "code": "W11"}, "not a control box error"),
    ({"cmd": "error", "code": "banana"}, "not an error label"),
    ({"cmd": "error"}, "code must be"),
    ({"cmd": "warning", "code": "C31"}, "not a warning"),
    ({"cmd": "servo-error", "joint": 7, "code": "S23"}, "joint 7 out of range 1..6"),
    ({"cmd": "servo-error", "joint": 0, "code": "S23"}, "out of range"),
    ({"cmd": "servo-error", "joint": "x", "code": "S23"}, "joint must be an integer"),
    ({"cmd": "servo-error", "joint": 3, "code": "G11"}, "not a servo error"),
    ({"cmd": "gripper-error", "code": "S23"}, "not a gripper error"),
    ({"cmd": "report-pause", "seconds": "forever"}, "not a duration"),
    ({"cmd": "reply-delay", "seconds": -1}, "out of range"),
    ({"cmd": "reply-delay", "seconds": float("nan")}, "must be a number"),
    ({"cmd": "set-input", "kind": "cgpio", "index": 99, "value": 1}, "cgpio input 99"),
    ({"cmd": "set-input", "kind": "cgpio", "index": 1, "value": 2}, "0 or 1"),
    ({"cmd": "set-input", "kind": "laser", "index": 1, "value": 1}, "unknown input kind"),
    ({"cmd": "collision", "joint": 7, "torque": 50}, "joint 7 out of range"),
    ({"cmd": "set-input", "kind": "vacuum-object", "index": 0, "value": 0}, "no vacuum gripper"),
    ({"cmd": "set-input", "kind": "vacuum-object", "index": 0, "value": 2}, "must be 0 or 1"),
    ({"cmd": "collision", "joint": 2, "torque": "hard"}, "torque must be a number"),
    ({"cmd": "collision", "joint": 2, "torque": "nan"}, "torque must be finite"),
    ({"cmd": "set-input", "kind": "analog", "index": 5, "value": 1.0}, "analog input 5"),
])
def test_bad_requests_are_refused_and_change_nothing(srv: ServerThread, admin: AdminClient,
                                                     request_: dict[str, Any], fragment: str) -> None:
    before = fault_state(srv)
    answer = admin.send(request_)
    assert answer["ok"] is False
    assert fragment in answer["error"]
    assert fault_state(srv) == before


def test_malformed_lines_are_refused(srv: ServerThread) -> None:
    before = fault_state(srv)
    with socket.create_connection(("127.0.0.1", srv.ports["admin"]), timeout=2) as s:
        f = s.makefile("rb")
        for line in (b"not json\n", b"[1, 2]\n", b"\xff\xfe\n"):
            s.sendall(line)
            answer = json.loads(f.readline())
            assert answer == {"ok": False, "error": "not a JSON object line"}
        s.sendall(b"x" * 5000)
        assert "longer than" in json.loads(f.readline())["error"]
        assert f.readline() == b""  # closed
        f.close()
    assert fault_state(srv) == before


def test_admin_client_raises_refusal(admin: AdminClient) -> None:
    with pytest.raises(AdminRefused, match="unknown command"):
        admin.request("nope")


class _FakeTransport(asyncio.Transport):
    def __init__(self, peer: tuple[str, int]) -> None:
        super().__init__()
        self.peer = peer
        self.written = b""
        self.closed = False

    def get_extra_info(self, name: str) -> Any:
        return self.peer if name == "peername" else None

    def write(self, data: bytes) -> None:
        self.written += data

    def is_closing(self) -> bool:
        return self.closed

    def close(self) -> None:
        self.closed = True


@pytest.mark.parametrize("peer", ["10.0.0.5", "192.168.1.20", "::ffff:10.1.2.3", "2001:db8::1"])
def test_non_loopback_peer_is_refused(srv: ServerThread, peer: str) -> None:
    before = fault_state(srv)
    proto = AdminProtocol(srv.server)
    t = _FakeTransport((peer, 40000))
    proto.connection_made(t)  # type: ignore[arg-type]
    assert t.closed
    answer = json.loads(t.written)
    assert answer["ok"] is False and "loopback" in answer["error"] and peer in answer["error"]
    proto.data_received(json.dumps({"cmd": "estop"}).encode() + b"\n")
    assert fault_state(srv) == before
    assert proto not in srv.server.admin_clients


@pytest.mark.parametrize("host, loop", [("127.0.0.1", True), ("127.8.9.1", True), ("::1", True),
                                        ("::ffff:127.0.0.1", True), ("10.0.0.1", False), ("", False),
                                        ("localhost", False)])
def test_is_loopback(host: str, loop: bool) -> None:
    assert is_loopback(host) is loop


@pytest.mark.parametrize("text, seconds", [("2s", 2.0), ("50ms", 0.05), ("0.5", 0.5), ("250us", 250e-6),
                                           (" 1.5S ", 1.5)])
def test_parse_duration(text: str, seconds: float) -> None:
    assert parse_duration(text) == pytest.approx(seconds)
