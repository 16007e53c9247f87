"""One client method per register, generated from the register table (issue 2 item 7)."""

from __future__ import annotations

import asyncio
import math

import pytest

from xarm_emu.client import AsyncClient, Client
from xarm_emu.protocol.registers import REGISTERS


def test_every_register_has_a_method_on_both_twins() -> None:
    for reg in REGISTERS.values():
        name = reg.name.lower()
        assert callable(getattr(Client, name)), name
        assert callable(getattr(AsyncClient, name)), name
        assert asyncio.iscoroutinefunction(getattr(AsyncClient, name)), name


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
