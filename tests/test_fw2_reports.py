"""The report streams follow the firmware profile: a 2.x box sends 587-byte rich and 135-byte develop
frames and, from 2.1.0, the real-time report on its own port; 1.6.0 keeps the manual's frames and has
no real-time port. The SDK's own report parsers read the joints, pose, state and counter the
registers answer."""

from __future__ import annotations

import math
import socket
import struct
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from xarm_emu.model import rotations as rot
from xarm_emu.protocol import reports
from xarm_emu.protocol.firmware import profile_for
from xarm_emu.server.thread import ServerThread
from xarm_emu.testing import running_emulator

FW2 = "2.7.103"


def _read_frames(port: int, n: int, timeout: float = 5.0) -> list[bytes]:
    """The next ``n`` whole frames of a report port (length-prefixed, section 2.1.6)."""
    out: list[bytes] = []
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
        buf = b""
        while len(out) < n:
            while len(buf) < 4 or len(buf) < struct.unpack_from(">I", buf)[0]:
                chunk = s.recv(65536)
                if not chunk:
                    raise ConnectionError("report port closed")
                buf += chunk
            size = struct.unpack_from(">I", buf)[0]
            out.append(buf[:size])
            buf = buf[size:]
    return out


@pytest.fixture(scope="module")
def fw2() -> Iterator[ServerThread]:
    with running_emulator(firmware=FW2) as st:
        yield st


def _enable(st: ServerThread) -> None:
    emu = st.emulator

    def go() -> None:
        emu.handle(11, bytes([8, 1]))
        emu.handle(19, bytes([0, 0]))
        emu.handle(12, bytes([0]))

    st.call(go)


@pytest.mark.parametrize("version", ["1.6.0", "1.11.100", "2.0.102", "2.4.101", "2.7.103"])
def test_frame_sizes_and_ports_follow_the_firmware(version: str) -> None:
    profile = profile_for(version)
    with running_emulator(firmware=version) as st:
        rich = _read_frames(st.ports["rich"], 1)[0]
        develop = _read_frames(st.ports["develop"], 2)[-1]
        normal = _read_frames(st.ports["normal"], 1)[0]
        # the 2.x frames: rich 587 bytes, develop 135 (with the F/T tail); the manual's 433 and 87
        rich_size, develop_size = (587, 135) if profile.reports_2x else (433, 87)
        assert len(rich) == struct.unpack_from(">I", rich)[0] == rich_size
        assert len(develop) == struct.unpack_from(">I", develop)[0] == develop_size
        assert len(normal) == reports.NORMAL_SIZE
        assert ("realtime" in st.ports) == profile.realtime_report
        if profile.realtime_report:
            rt = _read_frames(st.ports["realtime"], 1)[0]
            assert len(rt) == struct.unpack_from(">I", rt)[0] == reports.REALTIME_SIZE


def test_1_6_0_rich_counter_stays_the_commands_completed() -> None:
    with running_emulator() as st:
        _enable(st)
        st.call(lambda: setattr(st.emulator.controller, "user_counter", 77))
        frame = _read_frames(st.ports["rich"], 1)[0]
        done = st.emulator.controller.executor.completed
    assert reports.decode_rich(frame).counter == done


def test_2x_rich_frame_carries_the_user_counter_pose_aa_and_the_settings(fw2: ServerThread) -> None:
    _enable(fw2)
    ctl = fw2.emulator.controller

    def setup() -> None:
        ctl.user_counter = 1234
        ctl.settings.report_current = True
        ctl.settings.boundary = [500, -400, 300, -200, 600, -100]
        ctl.settings.boundary_on = True

    fw2.call(setup)
    try:
        frame = _read_frames(fw2.ports["rich"], 2)[-1]
        snap = reports.decode_rich2(frame)
        pose = fw2.call(lambda: ctl.tcp_pose())
    finally:
        def undo() -> None:
            ctl.user_counter = 0
            ctl.settings.report_current = False
            ctl.settings.boundary_on = False
        fw2.call(undo)
    assert struct.unpack_from(">I", frame, 284)[0] == 1234
    assert snap.report_current and snap.fence
    assert snap.reduced_tcp_boundary == (500, -400, 300, -200, 600, -100)
    aa = rot.rpy_to_axis_angle(*pose[3:6])  # type: ignore[index]
    R = rot.axis_angle_to_matrix(snap.pose_aa)
    assert np.allclose(R, rot.axis_angle_to_matrix(aa), atol=1e-5)
    assert snap.joints[:6] == pytest.approx(list(fw2.emulator.controller.q), abs=1e-6)


def test_realtime_frames_carry_controller_microseconds_and_joints(fw2: ServerThread) -> None:
    _enable(fw2)
    fw2.call(lambda: fw2.emulator.handle(23, struct.pack("<10f", 0.5, 0, 0, 0, 0, 0, 0, 0.5, 5.0, 0) + b"\0"))
    t0 = time.monotonic()
    frames = _read_frames(fw2.ports["realtime"], 40)
    elapsed = time.monotonic() - t0
    snaps = [reports.decode_realtime(f) for f in frames]
    stamps = [s.timestamp_us for s in snaps]
    assert stamps == sorted(stamps) and stamps[-1] > stamps[0]
    assert elapsed < 40 / reports.REALTIME_RATE * 4  # about 250 Hz, not the rich stream's 5 Hz
    now_us = fw2.emulator.time * 1e6
    assert now_us - 1e6 < stamps[-1] <= now_us
    j1 = [s.joints[0] for s in snaps]
    assert j1[-1] > j1[0]  # the move runs and the stream shows it
    assert all(s.state == 1 for s in snaps[-5:])


@pytest.fixture
def arm(fw2: ServerThread, sdk_arm: Callable[..., Any]) -> Callable[[str], Any]:
    def make(report_type: str) -> Any:
        a = sdk_arm(fw2, report_type=report_type)
        a.motion_enable(True)
        a.set_mode(0)
        a.set_state(0)
        return a
    return make


def _until(cond: Callable[[], bool], timeout: float = 3.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


@pytest.mark.parametrize("report_type", ["rich", "real"])
def test_the_sdk_report_parsers_read_what_the_registers_answer(fw2: ServerThread, arm: Callable[[str], Any],
                                                               report_type: str) -> None:
    a = arm(report_type)
    assert a.set_servo_angle(angle=[20, -15, -20, 0, 35, 10], speed=80, wait=True) == 0
    assert _until(lambda: a.state == 2)
    code, joints = a.get_servo_angle()
    code2, pose = a.get_position()
    assert code == code2 == 0
    assert _until(lambda: a.angles[:6] == pytest.approx(joints[:6], abs=1e-3))
    assert a.position == pytest.approx(pose, abs=1e-3)
    assert a.error_code == 0 and a.mode == 0
    if report_type == "rich":
        rpy = [math.radians(v) for v in pose[3:6]]
        aa = [math.degrees(v) for v in rot.rpy_to_axis_angle(*rpy)]
        # the SDK joins these angles with the position of the frame before: one more frame
        assert _until(lambda: a.position_aa[:3] == pytest.approx(pose[:3], abs=1e-3))
        assert np.allclose(rot.axis_angle_to_matrix(np.radians(a.position_aa[3:6])),
                           rot.axis_angle_to_matrix(np.radians(aa)), atol=1e-4)
        fw2.call(lambda: setattr(fw2.emulator.controller, "user_counter", 9))
        try:
            assert _until(lambda: a.count == 9)
        finally:
            fw2.call(lambda: setattr(fw2.emulator.controller, "user_counter", 0))
    else:
        assert a.ft_ext_force == pytest.approx([0.0] * 6)
        assert a.ft_raw_force == pytest.approx([0.0] * 6)


@pytest.mark.parametrize("report_type", ["rich", "real"])
def test_the_sdk_report_parsers_read_errors_and_warnings(sdk_arm: Callable[..., Any],
                                                         report_type: str) -> None:
    with running_emulator(firmware=FW2) as st:
        a = sdk_arm(st, report_type=report_type)
        st.call(lambda: st.emulator.inject_error(31))
        code, (err, warn) = a.get_err_warn_code()
        assert (code, err, warn) == (0, 31, 0)
        assert _until(lambda: a.error_code == 31)
        assert _until(lambda: a.state == 4)
        a.clean_error()
        assert a.get_err_warn_code()[1][0] == 0
        if report_type == "rich":  # the develop stream carries no error code: only the rich one clears it
            assert _until(lambda: a.error_code == 0)
        a.disconnect()


def test_rich_report_carries_the_reduced_mode_and_motion_flags_the_registers_set() -> None:
    """Rich bytes 433-586 of a 2.x box show the reduced mode of registers 47, 48 and 50 and the
    flags of registers 66 and 80, as registers 53 and the SDK's report parser read them."""
    from xarm_emu.controller.emulator import Emulator
    from xarm_emu.protocol import reports

    emu = Emulator(6, firmware="2.7.103")
    table = emu.controller.registers
    for code, values in ((47, {"speed": 250.0}), (48, {"speed": 1.5}), (50, {"on": 1}),
                         (66, {"on": 1}), (80, {"on": 1})):
        layout = table[code].request
        values = {f.name: values.get(f.name, 1) for f in layout.fields}
        state, _ = emu.handle(code, layout.encode(values))
        assert state & 0x60 == 0, code
    frame = reports.encode_rich2(emu.snapshot())  # the 2.x fields included
    got = reports.decode_rich2(frame)
    assert got.reduced_mode is True
    assert got.reduced_max_tcp_speed == pytest.approx(250.0)
    assert got.reduced_max_joint_speed == pytest.approx(1.5)
    assert got.approx_motion is True and got.cart_continuous is True
