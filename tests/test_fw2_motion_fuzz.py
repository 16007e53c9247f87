"""Random requests to the 2.x motion registers (relative moves, velocity control, online targets,
trajectories, reduced mode) in every mode they touch: the controller never raises, every reply has
its register's length, and the arm never leaves its joint limits."""

from __future__ import annotations

import os
import struct
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_fw2_motion import call, ready

from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import kinematics as kin
from xarm_emu.protocol.firmware import NEWEST_PROFILE
from xarm_emu.protocol.registers import registers_for

TABLE = registers_for(NEWEST_PROFILE)
CODES = [12, 19, 21, 23, 47, 48, 49, 50, 53, 58, 60, 61, 62, 63, 64, 65, 81, 82, 83, 230]
SCALE = max(1, int(os.environ.get("XARM_EMU_FUZZ_SCALE", "1")))


def sizes(code: int) -> list[int]:
    layout = TABLE[code].request
    options = getattr(layout, "options", None)
    return sorted({n for opt in options for n in opt.sizes()} if options else set(layout.sizes()))


@st.composite
def requests(draw: st.DrawFn) -> tuple[int, bytes]:
    code = draw(st.sampled_from(CODES))
    size = draw(st.sampled_from(sizes(code)))
    if code == 19:
        return code, bytes([draw(st.sampled_from([0, 1, 2, 4, 5, 6, 7, 11, 200]))]) + b"\x00" * (size - 1)
    if code == 12:
        return code, bytes([draw(st.sampled_from([0, 3, 4]))])
    if code in (62, 63):
        name = draw(st.sampled_from([b"a.traj", b"../x", b"", b"\xff\xfe", b"b" * 81]))
        return code, name[:81].ljust(81, b"\0")
    if draw(st.booleans()):
        floats = draw(st.lists(st.sampled_from([0.0, 0.1, -0.1, 1.0, -1.0, 0.5, 3.1416, 30.0, 100.0, 1e9,
                                                -1e9, 3.0e38, 1e-40, float("nan"), float("inf"),
                                                float("-inf")]), min_size=size // 4, max_size=size // 4))
        raw = struct.pack(f"<{len(floats)}f", *floats)
        tail = draw(st.lists(st.sampled_from([0, 1, 2, 255]), min_size=size % 4, max_size=size % 4))
        return code, raw + bytes(tail)
    return code, draw(st.binary(min_size=size, max_size=size))


@settings(max_examples=300 * SCALE, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(reqs=st.lists(requests(), min_size=1, max_size=14), mode=st.sampled_from([0, 2, 4, 5, 6, 7]))
def test_random_2x_motion_requests_never_raise(reqs: list[tuple[int, bytes]], mode: int) -> None:
    with tempfile.TemporaryDirectory() as d:
        emu = Emulator(6, firmware=str(NEWEST_PROFILE), config_dir=Path(d))
        ctl = emu.controller
        ctl.strict = True
        ready(emu, mode=mode)
        for code, raw in reqs:
            if code in (21, 23) and ctl.mode not in (6, 7):
                continue  # queued moves of position mode belong to the motion fuzz, not this one
            state, reply = emu.handle(code, raw)
            assert 0 <= state <= 0xFF
            if reply:
                assert TABLE[code].reply.accepts(len(reply)), (code, len(reply))
            emu.step(10)
            assert kin.within_limits(ctl.model, ctl.q)
        emu.advance(1.0)
        assert call(emu, 13)[1]["state"] in (1, 2, 3, 4, 5)
