"""``xarm-emu checkpoint save|restore|list`` over the admin channel, against the admin socket of a
fake server whose emulator records the checkpoint calls."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from typing import Any

import pytest
from helpers import run_cli
from test_server_admin_target import FakeTarget, RecordingEmulator

from xarm_emu.server.admin_port import AdminProtocol


class FakeHost(FakeTarget):
    def __init__(self, emulator: Any) -> None:
        super().__init__(emulator)
        self.admin_clients: set[AdminProtocol] = set()

    def catch_up(self) -> int:
        return 0


@pytest.fixture
def channel() -> Iterator[tuple[FakeHost, list[str]]]:
    """A fake host's admin channel on a free loopback port; yields it and the CLI's address options."""
    host = FakeHost(RecordingEmulator())
    loop = asyncio.new_event_loop()
    server = loop.run_until_complete(loop.create_server(lambda: AdminProtocol(host), "127.0.0.1", 0))
    port = server.sockets[0].getsockname()[1]
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        yield host, ["--port", "502", "--admin-port", str(port)]
    finally:
        async def close() -> None:
            server.close()
            for c in tuple(host.admin_clients):
                if c.transport is not None:
                    c.transport.abort()
            await server.wait_closed()
            await asyncio.sleep(0)

        asyncio.run_coroutine_threadsafe(close(), loop).result(5)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(5)
        loop.close()


def test_save_list_restore(channel: tuple[FakeHost, list[str]]) -> None:
    host, addr = channel
    code, out = run_cli("checkpoint", "list", *addr)
    assert (code, out) == (0, "")
    assert run_cli("checkpoint", "save", "before-pick", *addr)[0] == 0
    assert run_cli("checkpoint", "save", "after", *addr)[0] == 0
    code, out = run_cli("checkpoint", "list", *addr)
    assert (code, out.splitlines()) == (0, ["after", "before-pick"])
    code, out = run_cli("checkpoint", "restore", "before-pick", *addr)
    assert code == 0 and "restored" in out
    assert host.emulator.calls == [("checkpoint",), ("checkpoint",), ("restore", ("state", 1))]


@pytest.mark.parametrize("args, fragment", [
    (["restore", "never"], "no checkpoint 'never'"),
    (["save", "   "], "non-empty"),
    (["save", "x" * 65], "longer than 64"),
])
def test_bad_calls_exit_2_with_one_line(channel: tuple[FakeHost, list[str]], args: list[str],
                                        fragment: str) -> None:
    host, addr = channel
    code, out = run_cli("checkpoint", *args, *addr)
    assert code == 2 and fragment in out and len(out.strip().splitlines()) == 1
    assert host.emulator.calls == []


def test_without_an_admin_channel_exits_1() -> None:
    from helpers import free_ports

    (port,) = free_ports(1)
    code, out = run_cli("checkpoint", "save", "a", "--port", "502", "--admin-port", str(port))
    assert code == 1 and "cannot reach the admin channel" in out
