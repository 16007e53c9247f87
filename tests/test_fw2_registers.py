"""The registers the SDK sends beyond manual V1.6.0 (other than motion and feedback), through the
register table under a 2.x profile: what each answers and what it changes."""

from __future__ import annotations

import math
import re
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xarm_emu.controller.core.interface import WARN_PARAMETER, WARN_UNKNOWN_COMMAND
from xarm_emu.controller.devices.gripper import GRIPPER_ID, crc16_modbus
from xarm_emu.controller.emulator import Emulator
from xarm_emu.controller.handlers import force_control, ft_sensor, service
from xarm_emu.model import rotations as rot
from xarm_emu.protocol import rtu
from xarm_emu.protocol.firmware import NEWEST_PROFILE
from xarm_emu.protocol.frame import STATE_ERROR, STATE_WARNING
from xarm_emu.protocol.layouts import Layout
from xarm_emu.protocol.registers import registers_for

FW2 = "2.7.103"



def sdk_registers() -> dict[int, str]:
    """Every register the installed SDK can send: the constants of its ``UxbusReg`` that some line
    of its code (not a comment) uses."""
    import xarm
    from xarm.core.config.x_config import XCONF

    names = {n: v for n, v in vars(XCONF.UxbusReg).items() if n.isupper() and isinstance(v, int)}
    used: set[str] = set()
    pattern = re.compile(r"UxbusReg\.([A-Z0-9_]+)")
    for path in Path(xarm.__file__).parent.rglob("*.py"):
        for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
            code = line.split("#", 1)[0]
            used.update(pattern.findall(code))
    return {v: n for n, v in names.items() if n in used and 0 < v < 256}


def _full_form(layout: Layout) -> Layout:
    options = getattr(layout, "options", ())
    return options[-1] if options else layout


#: Requests with meaning where all-zero bytes are not a valid request.
VALID: dict[int, bytes] = {
    6: bytes([1]),
    19: bytes([0, 0]),
    68: struct.pack("<28f", *([0.0] * 28)) + bytes([0]),
    115: b"XI1300" + bytes(8),
    124: bytes([9]) + rtu.read_request(GRIPPER_ID, 0x0702, 2),
    127: bytes([9, 0x0A, 0x15]) + struct.pack("<f", 257.0) + bytes([0]),
    128: bytes([9, 0x0A, 0x14]),
    129: bytes([GRIPPER_ID, 0x07, 0x00]) + struct.pack("<f", 100.0),
    130: bytes([GRIPPER_ID, 0x07, 0x02]),
    123: struct.pack(">H", 20),
    240: struct.pack(">H", 20),
    230: bytes([1]),
    232: bytes([1]) + struct.pack("<f", 0.5),
    233: bytes([1]),
    234: bytes([1]),
    241: bytes([9, 0]),
    101: bytes([1, 0x10, 0x00]) + struct.pack("<f", 5.0),
    102: bytes([1, 0x08, 0x01]),
    103: bytes([1, 0x10, 0x00]) + struct.pack("<f", 5.0),
    104: bytes([1, 0x08, 0x01]),
    105: bytes([1]),
    107: bytes([1, 0x08, 0x01]),
}


def _touching_poses(tool: np.ndarray, point: np.ndarray) -> list[float]:
    """Four flange poses (x, y, z, roll, pitch, yaw) that put the tool point ``tool`` on ``point``."""
    poses: list[float] = []
    for rpy in ((math.pi, 0.0, 0.0), (math.pi, 0.3, 0.0), (math.pi - 0.3, 0.0, 0.5), (math.pi, -0.2, 1.0)):
        R = rot.rpy_to_matrix(*rpy)
        poses.extend([*(point - R @ tool), *rpy])
    return poses


# Admittance masses inside the vendor's ranges (0.02-1 kg, 0.0001-0.01 kg m^2); K and B zero.
_MKB = struct.pack("<18f", *([0.06] * 3 + [0.001] * 3), *([0.0] * 12))
VALID[207] = bytes([1, 0, 0, 1, 0, 0, 0]) + _MKB
VALID[210] = _MKB
VALID[111] = struct.pack("<24f", *_touching_poses(np.array([0.0, 0.0, 100.0]), np.array([300.0, 0, 100.0])))


def valid_request(code: int, layout: Layout) -> bytes:
    if code in VALID:
        return VALID[code]
    full = _full_form(layout)
    return bytes(full.size + (full.rest_min if full.rest else 0))


@pytest.fixture
def box() -> Emulator:
    emu = Emulator(6, firmware=FW2)
    for code, params in ((11, bytes([8, 1])), (19, bytes([0, 0])), (12, bytes([0]))):
        emu.handle(code, params)
    return emu


def call(emu: Emulator, code: int, params: bytes = b"") -> bytes:
    status, reply = emu.handle(code, params)
    assert not status & (STATE_ERROR | STATE_WARNING), (code, emu.controller.warning_code)
    return reply


def refused(emu: Emulator, code: int, params: bytes = b"") -> int:
    status, _ = emu.handle(code, params)
    assert status & STATE_WARNING
    w = emu.controller.warning_code
    emu.handle(17, b"")
    return w


# --- the test of record -----------------------------------------------------------------------------


def test_every_register_the_sdk_can_send_is_in_the_newest_table() -> None:
    table = registers_for(NEWEST_PROFILE)
    sent = sdk_registers()
    assert len(sent) > 130  # the SDK's own constants, not a copy of ours
    assert {c: n for c, n in sent.items() if c not in table} == {}


def test_no_register_the_sdk_can_send_answers_warning_13() -> None:
    table = registers_for(NEWEST_PROFILE)
    emu = Emulator(6, firmware=str(NEWEST_PROFILE.version))
    unknown = []
    for code in sorted(sdk_registers()):
        if code == 10:  # 10 shuts the box down
            continue
        emu.handle(17, b"")
        emu.handle(16, b"")
        emu.handle(code, valid_request(code, table[code].request))
        if emu.controller.warning_code == WARN_UNKNOWN_COMMAND:
            unknown.append(code)
    assert unknown == []


def _codes(*modules: Any) -> set[int]:
    """The register codes the handler modules bind."""
    return {row.code for m in modules for row in m.BINDINGS}


def test_the_registers_of_this_part_answer_their_reply_length_without_a_warning(box: Emulator) -> None:
    table = registers_for(NEWEST_PROFILE)
    refuse = {201, 202, 204, 206}  # they need the F/T sensor
    codes = sorted(_codes(service, ft_sensor, force_control) | {123, 125, 129, 130, 240, 241})
    for code in codes:
        if code in refuse:
            continue
        reply = call(box, code, valid_request(code, table[code].request))
        layout = table[code].reply
        if not layout.rest:
            assert len(reply) == layout.size, code


# --- counter ----------------------------------------------------------------------------------------


def test_counter_increases_and_resets(box: Emulator) -> None:
    for _ in range(3):
        call(box, 75)
    assert box.controller.user_counter == 3
    call(box, 74)
    assert box.controller.user_counter == 0


def test_counter_waits_its_turn_behind_queued_moves(box: Emulator) -> None:
    ctl = box.controller
    target = struct.pack("<10f", 0.5, 0, 0, 0, 0, 0, 0, 1.0, 10.0, 0.0)
    call(box, 23, target)
    call(box, 75)
    assert ctl.user_counter == 0 and ctl.executor.cmdnum == 2
    for _ in range(5000):
        box.step()
        if ctl.user_counter:
            break
    assert ctl.user_counter == 1
    assert abs(ctl.q[0] - 0.5) < 1e-6  # after the move ended


# --- approximate motion, continuous Cartesian velocity ----------------------------------------------


def test_approx_motion_switch_reads_back(box: Emulator) -> None:
    assert call(box, 7) == b"\x00"
    call(box, 66, b"\x01")
    assert call(box, 7) == b"\x01"
    assert refused(box, 66, b"\x02") == WARN_PARAMETER
    call(box, 80, b"\x01")
    from xarm_emu.controller.handlers.service import extra_state

    assert extra_state(box.controller).cartesian_velocity_continuous


# --- 46 is_tcp_limit ------------------------------------------------------------------------------


def test_is_tcp_limit(box: Emulator) -> None:
    home = struct.pack("<6f", 207.0, 0.0, 112.0, math.pi, 0.0, 0.0)
    far = struct.pack("<6f", 2000.0, 0.0, 112.0, math.pi, 0.0, 0.0)
    assert call(box, 46, home) == b"\x00"
    assert call(box, 46, far) == b"\x01"
    box.handle(52, struct.pack("<6i", 100, -100, 100, -100, 500, -500))
    box.handle(59, b"\x01")
    assert call(box, 46, home) == b"\x01"  # x = 207 is beyond the boundary's 100


# --- servo registers --------------------------------------------------------------------------------


def test_servo_version_and_harmonic_type_registers(box: Emulator) -> None:
    from xarm_emu.controller.handlers.service import HARMONIC_TYPE, SERVO_VERSION

    got = [struct.unpack(">i", call(box, 102, bytes([2, 0x08, a])))[0] for a in (1, 2, 3)]
    assert tuple(got) == SERVO_VERSION
    assert struct.unpack(">i", call(box, 102, bytes([2, 0x08, 0x1F])))[0] == HARMONIC_TYPE
    assert struct.unpack(">i", call(box, 107, bytes([2, 0x08, 0x01])))[0] >> 16 == SERVO_VERSION[0]
    assert refused(box, 102, bytes([9, 0x08, 0x01])) == WARN_PARAMETER
    call(box, 103, bytes([3, 0x12, 0x34]) + struct.pack("<f", 42.0))
    assert struct.unpack(">i", call(box, 104, bytes([3, 0x12, 0x34])))[0] == 42


# --- D-H, calibration, identification -------------------------------------------------------------


def test_dh_parameters_read_back(box: Emulator) -> None:
    dh = struct.unpack("<28f", call(box, 67))
    assert dh[0] == pytest.approx(267.0) and dh[6] == pytest.approx(289.4866)
    new = [float(i) for i in range(28)]
    assert call(box, 68, struct.pack("<28f", *new) + b"\x00") == b"\x00"
    assert list(struct.unpack("<28f", call(box, 67))) == new
    assert refused(box, 68, struct.pack("<28f", *new) + b"\x05") == WARN_PARAMETER


def test_tcp_position_calibration_finds_the_tool_point(box: Emulator) -> None:
    tool = np.array([10.0, -20.0, 150.0])
    point = np.array([400.0, 50.0, 100.0])
    poses = _touching_poses(tool, point)
    got = struct.unpack("<3f", call(box, 111, struct.pack("<24f", *poses)))
    assert np.allclose(got, tool, atol=1e-2)


def test_tcp_orientation_calibration(box: Emulator) -> None:
    be, bt = (math.pi, 0.0, 0.0), (math.pi, 0.0, 0.5)
    got = struct.unpack("<3f", call(box, 112, struct.pack("<6f", *be, *bt)))
    R = rot.rpy_to_matrix(*be) @ rot.rpy_to_matrix(*got)
    assert np.allclose(R, rot.rpy_to_matrix(*bt), atol=1e-5)


def test_friction_identification_checks_the_serial(box: Emulator) -> None:
    sn = box.controller.robot_sn.encode().ljust(14, b"\0")
    assert struct.unpack("<f", call(box, 115, sn))[0] == 0.0
    assert struct.unpack("<f", call(box, 115, b"LI1006".ljust(14, b"\0")))[0] == -1.0


# --- generic parameters ------------------------------------------------------------------------------


def test_common_parameters_read_back(box: Emulator) -> None:
    assert struct.unpack("<f", call(box, 233, b"\x01"))[0] == 1.0
    call(box, 232, b"\x01" + struct.pack("<f", 0.25))
    assert struct.unpack("<f", call(box, 233, b"\x01"))[0] == 0.25
    call(box, 232, b"\x0b" + struct.pack("<i", 1))
    assert call(box, 233, b"\x0b") == struct.pack(">I", 1)  # integers come back u32 BE
    call(box, 232, b"\x0c" + struct.pack("<6f", 1, 2, 3, 4, 5, 6))
    assert struct.unpack("<6f", call(box, 233, b"\x0c")) == (1, 2, 3, 4, 5, 6)
    assert refused(box, 232, b"\x63\x00") == WARN_PARAMETER
    assert refused(box, 232, b"\x01" + struct.pack("<f", math.nan)) == WARN_PARAMETER


def test_common_info_lengths(box: Emulator) -> None:
    assert call(box, 234, b"\x01") == b"\x00"
    assert len(call(box, 234, b"\x67")) == 29  # C23 details: bit mask and 7 angles
    assert refused(box, 234, b"\x09") == WARN_PARAMETER


# --- tool RS-485 -----------------------------------------------------------------------------------


def _gripper_read(box: Emulator) -> bytes:
    return call(box, 124, bytes([9]) + rtu.read_request(GRIPPER_ID, 0x0702, 2))[1:]


def test_tool_modbus_timeout_is_honoured(box: Emulator) -> None:
    assert _gripper_read(box)[1] == 0x03  # answered
    call(box, 123, struct.pack(">H", 1))  # shorter than the gripper takes to answer
    reply = _gripper_read(box)
    assert reply[1] == 0x83 and reply[2] == rtu.GATEWAY_NO_RESPONSE
    assert call(box, 233, b"\x04") == struct.pack(">I", 1)  # get_rs485_timeout reads it back
    call(box, 123, struct.pack(">H", 5))
    assert _gripper_read(box)[1] == 0x03
    assert refused(box, 123, struct.pack(">H", 0)) == WARN_PARAMETER


def test_transparent_rs485_answers_a_valid_frame(box: Emulator) -> None:
    frame = rtu.read_request(GRIPPER_ID, 0x0801, 3)
    reply = call(box, 241, bytes([9]) + frame + crc16_modbus(frame))
    assert reply[0] == 9 and reply[1:3] == bytes([GRIPPER_ID, 0x03])
    assert crc16_modbus(reply[1:-2]) == reply[-2:]
    assert call(box, 241, bytes([9]) + frame + b"\x00\x00") == b"\x09"  # bad CRC: no reply bytes
    call(box, 240, struct.pack(">H", 7))
    assert call(box, 233, b"\x05") == struct.pack(">I", 7)


def test_old_gripper_path(box: Emulator) -> None:
    g = box.gripper.gripper
    g.set_enable(1)
    call(box, 129, bytes([GRIPPER_ID, 0x07, 0x00]) + struct.pack("<f", 300.0))
    assert g.target == 300
    box.advance(3.0)
    assert struct.unpack(">i", call(box, 130, bytes([GRIPPER_ID, 0x07, 0x02])))[0] == 300
    box.inject_gripper_error(0x19)
    assert call(box, 125) == bytes([0, 0x19])


# --- F/T sensor, none attached ---------------------------------------------------------------------


def test_ft_sensor_absent(box: Emulator) -> None:
    assert struct.unpack("<6f", call(box, 200)) == (0.0,) * 6
    assert struct.unpack("<6f", call(box, 150)) == (0.0,) * 6
    assert refused(box, 201, b"\x01") == WARN_PARAMETER
    call(box, 201, b"\x00")
    assert call(box, 203) == b"\x00"
    call(box, 205, struct.pack("<10f", 0.8, 0.0, 0.0, 0.05, 1, 2, 3, 4, 5, 6))
    M = (0.02, 0.03, 0.04, 0.001, 0.002, 0.003)  # inside the vendor's ranges (outside: warning 12)
    call(box, 210, struct.pack("<18f", *M, *range(6, 18)))
    cfg = call(box, 212)
    assert len(cfg) == 280 and cfg[1] == 0  # not started
    assert struct.unpack("<f", cfg[6:10])[0] == pytest.approx(0.8)
    assert struct.unpack("<6f", cfg[57:81]) == pytest.approx(M)  # M


# --- sync byte and position triggers ---------------------------------------------------------------


def _move(box: Emulator, j1: float) -> None:
    call(box, 23, struct.pack("<10f", j1, 0, 0, 0, 0, 0, 0, 1.0, 10.0, 0.0))


def test_sync_byte_1_waits_for_the_queued_move_and_0_does_not(box: Emulator) -> None:
    io = box.io
    _move(box, 0.5)
    call(box, 134, struct.pack(">HB", 0x0101, 1))  # CO0 on, in turn
    call(box, 134, struct.pack(">HB", 0x0202, 0))  # CO1 on, at once
    assert io.cgpio.output(0) == 0 and io.cgpio.output(1) == 1
    box.advance(2.0)
    assert io.cgpio.output(0) == 1


def test_sync_byte_is_ignored_at_1_6_0() -> None:
    emu = Emulator(6)
    for code, params in ((11, bytes([8, 1])), (19, bytes([0])), (12, bytes([0]))):
        emu.handle(code, params)
    emu.handle(23, struct.pack("<10f", 0.5, 0, 0, 0, 0, 0, 0, 1.0, 10.0, 0.0))
    emu.handle(134, struct.pack(">HB", 0x0101, 1))
    assert emu.io.cgpio.output(0) == 1


def test_position_triggers_behind_200_moves_are_not_pending_yet(box: Emulator) -> None:
    for i in range(200):
        _move(box, 0.01 * (i % 2))
        status, _ = box.handle(147, struct.pack(">BH", 0, 100 + i) + struct.pack("<4f", 0, 0, 0, 1.0))
        assert not status & STATE_ERROR, i
    assert len(box.io.pending) <= 1
    assert box.controller.error_code == 0


def test_37_armed_triggers_are_still_c36(box: Emulator) -> None:
    params = struct.pack("<BB4f", 0, 1, 9000.0, 0.0, 0.0, 1.0)
    for _ in range(36):
        call(box, 144, params)
    status, _ = box.handle(144, params)
    assert status & STATE_ERROR and box.controller.error_code == 36


VALID[113] = struct.pack("<18f", 300, 0, 100, math.pi, 0, 0, 400, 0, 100, math.pi, 0, 0,
                         300, 100, 100, math.pi, 0, 0) + bytes([0, 0])


def test_user_frame_calibration(box: Emulator) -> None:
    got = struct.unpack("<3f", call(box, 113, VALID[113]))
    assert np.allclose(rot.rpy_to_matrix(*got), np.eye(3), atol=1e-6)  # the points span the base's xy
    origin = struct.unpack("<3f", call(box, 114, struct.pack("<6f", 0, 0, math.pi / 2, 100, 0, 0)))
    assert np.allclose(origin, (0.0, -100.0, 0.0), atol=1e-4)


def test_restore_puts_the_counter_and_settings_back(box: Emulator) -> None:
    cp = box.checkpoint()
    call(box, 75)
    call(box, 66, b"\x01")
    call(box, 123, struct.pack(">H", 3))
    call(box, 205, struct.pack("<10f", 0.8, 0, 0, 0, 0, 0, 0, 0, 0, 0))
    box.restore(cp)
    assert box.controller.user_counter == 0
    assert call(box, 7) == b"\x00"
    assert struct.unpack("<f", call(box, 212)[6:10])[0] == 0.0


# --- bad input --------------------------------------------------------------------------------------

_TABLE2 = registers_for(NEWEST_PROFILE)
_MINE = sorted(_codes(service, ft_sensor) | {123, 125, 127, 129, 130, 134, 135, 136, 144, 145, 147, 240, 241})


def test_random_requests_get_a_clear_answer() -> None:
    emu = Emulator(6, firmware=FW2)
    emu.controller.strict = True  # an unexpected exception fails instead of being logged
    for code, params in ((11, bytes([8, 1])), (19, bytes([0, 0])), (12, bytes([0]))):
        emu.handle(code, params)

    @settings(max_examples=400, deadline=None)
    @given(st.sampled_from(_MINE), st.binary(max_size=300))
    def run(code: int, params: bytes) -> None:
        status, reply = emu.handle(code, params)
        layout = _TABLE2[code].reply
        assert layout.rest or len(reply) == layout.size
        assert emu.controller.warning_code != WARN_UNKNOWN_COMMAND
        emu.step()
        emu.handle(17, b"")
        if status & STATE_ERROR:
            emu.handle(16, b"")
            emu.handle(12, bytes([0]))

    run()
