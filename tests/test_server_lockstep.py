"""Lockstep time (`serve --stepped --admin`): controller time advances only when the admin channel's
``step`` says so, and the result is the same as stepping the emulator in process."""

from __future__ import annotations

import json
import time

import pytest
from helpers import call, joints7, ready

from xarm_emu.client import Client
from xarm_emu.client.admin import AdminClient, AdminRefused
from xarm_emu.controller.emulator import Emulator
from xarm_emu.server.app import ServerConfig, ServerThread


def test_time_advances_only_by_step_and_matches_the_in_process_emulator(make_server) -> None:  # type: ignore[no-untyped-def]
    st = make_server(stepped=True, admin=True)
    with Client("127.0.0.1", st.ports["command"]) as c, AdminClient("127.0.0.1", st.ports["admin"]) as a:
        for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": 0}), (12, {"state": 0})):
            c.call(code, **values)
        c.call(23, joints=joints7(0.8, -0.3), speed=1.0, acc=8.0, mvtime=0.0)
        time.sleep(0.3)  # wall time passes, controller time does not
        assert c.get_joints()[:2] == (0.0, 0.0)
        assert json.loads(a.request("status"))["time"] == 0.0
        assert "125 control periods" in a.request("step", seconds="0.5s")
        served = c.get_joints()
    twin = Emulator(6)
    ready(twin)
    call(twin, 23, joints=joints7(0.8, -0.3), speed=1.0, acc=8.0, mvtime=0.0)
    twin.advance(0.5)
    assert served[:6] == pytest.approx(tuple(float(x) for x in twin.controller.q), abs=1e-7)
    assert 0.0 < served[0] < 0.8


def test_step_is_refused_in_real_time(make_server) -> None:  # type: ignore[no-untyped-def]
    st = make_server(admin=True)
    with AdminClient("127.0.0.1", st.ports["admin"]) as a, pytest.raises(AdminRefused, match="--stepped"):
        a.request("step", seconds=0.1)


def test_lockstep_needs_the_admin_channel(tmp_path) -> None:  # type: ignore[no-untyped-def]
    cfg = ServerConfig(port=0, normal_port=0, rich_port=0, develop_port=0, stepped=True)
    with pytest.raises(ValueError, match="--admin"):
        ServerThread(Emulator(6, config_dir=tmp_path), cfg).start()


def test_scaled_clock_caps_each_catch_up_and_keeps_the_rest_due() -> None:
    from xarm_emu.server.clock import ScaledClock

    clock = ScaledClock(0.004, speed=100.0)
    clock.start(0.0)
    assert clock.due(1.0, limit=250) == 250  # 1 wall s at x100 is 25000 periods: 250 now
    assert clock.due(1.0, limit=250) == 250  # the rest stays due
    assert clock.due(1.0) == 25000 - 500
    assert clock.due(1.0) == 0
    assert clock.due(1.004) == 100
