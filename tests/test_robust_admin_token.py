"""The admin channel requires its token on every request: without it or with a wrong one the request
is refused and nothing changes; with it (read by ``AdminClient`` from the owner-only token file) the
request is carried out."""

from __future__ import annotations

import json
import os
import socket
import stat
from pathlib import Path

import pytest

from xarm_emu.client.admin import AdminClient, AdminRefused
from xarm_emu.controller.core.config import admin_token_path, load_or_create_admin_token, read_admin_token
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerConfig, ServerThread


@pytest.fixture
def token_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    path = tmp_path / "home" / "admin-token"
    monkeypatch.setenv("XARM_EMU_ADMIN_TOKEN_FILE", str(path))
    return path


def _raw(port: int, obj: dict[str, object]) -> dict[str, object]:
    with socket.create_connection(("127.0.0.1", port), timeout=3.0) as s:
        s.sendall(json.dumps(obj).encode() + b"\n")
        answer: dict[str, object] = json.loads(s.makefile("rb").readline())
    return answer


def _config() -> ServerConfig:
    return ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0, admin=True,
                        admin_port=0)


def test_a_request_without_the_token_is_refused_and_with_it_accepted(token_file: Path) -> None:
    with ServerThread(Emulator(6), _config()) as st:
        assert admin_token_path() == token_file
        token = read_admin_token()
        assert token is not None and len(token) >= 32
        assert stat.S_IMODE(token_file.stat().st_mode) == 0o600
        port = st.ports["admin"]
        for bad in ({"cmd": "error", "code": "C31"}, {"cmd": "error", "code": "C31", "token": "x" * 32}):
            answer = _raw(port, bad)
            assert answer["ok"] is False and "admin token" in str(answer["error"])
        assert st.emulator.controller.error_code == 0  # refused: nothing changed
        with AdminClient("127.0.0.1", port, token="nope") as a, pytest.raises(AdminRefused, match="token"):
            a.request("status")
        with AdminClient("127.0.0.1", port) as a:  # reads the token file
            assert "C31" in a.request("error", code="C31")
        assert st.emulator.controller.error_code == 31


def test_the_token_is_created_once_and_kept(token_file: Path) -> None:
    first = load_or_create_admin_token()
    assert load_or_create_admin_token() == first
    os.chmod(token_file, 0o644)
    assert load_or_create_admin_token() == first
    assert stat.S_IMODE(token_file.stat().st_mode) == 0o600  # made owner-only again
