"""Lockstep time (`serve --stepped --admin`): controller time advances only when the admin channel's
``step`` says so, and the result is the same as stepping the emulator in process."""

from __future__ import annotations

import json
import time

import pytest
from helpers import call, joints7, ready
from hypothesis import given, settings
from hypothesis import strategies as hs

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


@settings(max_examples=200, deadline=None)
@given(speed=hs.sampled_from([0.001, 0.1, 1.0, 3.0, 100.0, 1e5]),
       start=hs.floats(0.0, 1e6),
       gaps=hs.lists(hs.floats(0.0, 0.02), min_size=1, max_size=60))
def test_scaled_clock_counts_the_periods_its_arithmetic_gives(speed: float, start: float,
                                                              gaps: list[float]) -> None:
    """Whatever shortcut ``due`` takes, the periods run by each wall time are those of
    int((wall - start) * speed / period), never more and never fewer."""
    from xarm_emu.server.clock import ScaledClock

    period = 0.004
    clock = ScaledClock(period, speed=speed)
    clock.start(start)
    wall, total = start, 0
    for gap in gaps:
        wall += gap
        total += clock.due(wall)
        assert total == max(0, int((wall - start) * speed / period))
        assert clock.due(wall) == 0
