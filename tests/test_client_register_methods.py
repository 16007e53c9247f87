"""One client method per register, generated from the register table: each twin's method sends its
own register's request, and both twins answer the same through a real server."""

from __future__ import annotations

import asyncio
import math
from typing import Any

import pytest

from xarm_emu.client import AsyncClient, Client, Response
from xarm_emu.client.helpers import Helpers
from xarm_emu.protocol.registers import REGISTERS

# registers whose method is a typed helper with its own parameters (tested in test_client_twins)
_TYPED = {name for name in dir(Helpers) if not name.startswith("_")}
_GENERIC = [reg for reg in REGISTERS.values() if reg.name.lower() not in _TYPED]


class _Recording:
    """Stands in for a connection: records what a method asks ``call`` for."""

    def __init__(self) -> None:
        self.calls: list[tuple[int | str, bytes | None, dict[str, Any]]] = []

    def answer(self, register: int | str, raw: bytes | None, values: dict[str, Any]) -> Response:
        self.calls.append((register, raw, values))
        return Response(int(register), 0, {"echo": dict(values)}, raw or b"")


class SyncRecording(Client):
    def __init__(self) -> None:  # no socket
        self.rec = _Recording()

    def call(self, register: int | str, raw: bytes | None = None, **values: Any) -> Response:
        return self.rec.answer(register, raw, values)


class AsyncRecording(AsyncClient):
    def __init__(self) -> None:  # no streams
        self.rec = _Recording()

    async def call(self, register: int | str, raw: bytes | None = None, **values: Any) -> Response:
        return self.rec.answer(register, raw, values)


@pytest.mark.parametrize("reg", _GENERIC, ids=lambda r: r.name)
def test_each_register_method_sends_its_own_register_on_both_twins(reg) -> None:  # type: ignore[no-untyped-def]
    name = reg.name.lower()
    sync, aio = SyncRecording(), AsyncRecording()
    r1 = getattr(sync, name)(speed=1.5)
    r2 = asyncio.run(getattr(aio, name)(b"\x01\x02"))
    assert sync.rec.calls == [(reg.code, None, {"speed": 1.5})]
    assert aio.rec.calls == [(reg.code, b"\x01\x02", {})]
    assert r1.register == r2.register == reg.code and r1["echo"] == {"speed": 1.5}
    assert f"Register {reg.code}," in getattr(Client, name).__doc__


def test_generated_methods_speak_the_table(server) -> None:  # type: ignore[no-untyped-def]
    port = server.ports["command"]
    with Client("127.0.0.1", port) as c:
        r = c.get_tcp_pose()
        assert r.register == 41 and r["pose"][:3] == pytest.approx((207.0, 0.0, 112.0), abs=1e-3)
        r = c.get_fk(joints=(math.pi / 2, 0, 0, 0, 0, 0, 0))
        assert r["pose"][:3] == pytest.approx((0.0, 207.0, 112.0), abs=1e-3)
        assert c.motion_en(joint=8, enable=1).not_ready  # a system reset: 0x10
        assert c.set_mode(0).not_ready
        assert not c.set_state(0).not_ready
        r = c.is_joint_limit(joints=(0.0, 3.0, 0, 0, 0, 0, 0))
        assert r["limited"] == 1

    async def run() -> None:
        c = await AsyncClient.connect("127.0.0.1", port)
        try:
            r = await c.get_error()
            assert r.values == {"error": 0, "warning": 0}
            r = await c.get_ik(pose=(207.0, 0.0, 112.0, math.pi, 0.0, 0.0))
            assert r["joints"][:6] == pytest.approx((0.0,) * 6, abs=1e-5)
            r = await c.move_joint(joints=(0.1, 0, 0, 0, 0, 0, 0), speed=1.0, acc=10.0, mvtime=0.0)
            assert r["cmdnum"] == 1 and not r.has_error
        finally:
            await c.close()

    asyncio.run(run())
