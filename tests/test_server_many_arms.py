"""Many arms on one host: the SDK's ports are fixed (502, 30001-30003), so each emulated arm gets a
loopback address of its own (127.0.0.0/8 on Linux) with the same port numbers."""

from __future__ import annotations

import socket

import pytest

from xarm_emu.client import Client
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerConfig, ServerThread


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_two_arms_on_two_loopback_addresses_with_the_same_ports(tmp_path) -> None:  # type: ignore[no-untyped-def]
    try:
        with socket.socket() as s:
            s.bind(("127.0.0.2", 0))
    except OSError:
        pytest.skip("this system routes only 127.0.0.1: run on Linux, which routes all of 127.0.0.0/8")
    ports = {"port": _free_port(), "normal_port": _free_port(), "rich_port": _free_port(),
             "develop_port": _free_port()}
    arms = []
    try:
        for i, (host, dof) in enumerate((("127.0.0.1", 6), ("127.0.0.2", 7))):
            emu = Emulator(dof, config_dir=tmp_path / str(i))
            arms.append(ServerThread(emu, ServerConfig(host=host, **ports)).start())
        with Client("127.0.0.1", ports["port"]) as a, Client("127.0.0.2", ports["port"]) as b:
            assert a.get_version().startswith("6,6,")
            assert b.get_version().startswith("7,7,")
            assert a.get_position()[:3] == pytest.approx((207.0, 0.0, 112.0), abs=1e-3)
            assert b.get_position()[:3] == pytest.approx((206.0, 0.0, 120.5), abs=1e-3)
    finally:
        for st in arms:
            st.stop()
