"""Report frames of ports 30003/30001/30002 (manual section 2.1.6).

Offsets below are written from the manual's byte numbering (1-based, "byte N" is at index N-1),
independently of the module's own layout tables.

Firmware 2.x report frames: the 587-byte rich report, the 135-byte develop report and the
804-byte real-time report of port 30000, read back through the SDK's own parsers.

Offsets are the SDK's 0-based reading of the 2.x tails; the manual V1.6.0 stops at 433 bytes.
"""

from __future__ import annotations

import math
import struct
from dataclasses import replace
from types import SimpleNamespace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xarm_emu.protocol import reports as R
from xarm_emu.protocol.firmware import DEFAULT_PROFILE, FirmwareProfile
from xarm_emu.protocol.reports import (
    DEVELOP_SIZE,
    NORMAL_SIZE,
    RICH_SIZE,
    ReportError,
    ReportSnapshot,
    decode_develop,
    decode_normal,
    decode_rich,
    encode_develop,
    encode_normal,
    encode_rich,
)

# Distinct values, all exactly representable in float32, so the wire keeps them unchanged.
JOINTS = (0.5, -1.25, 2.0, -0.75, 1.125, -2.5, 0.0625)
POSE = (207.5, -101.25, 112.0, 3.140625, -0.5, 1.5)
TORQUES = (1.5, -2.25, 3.0, -4.5, 5.25, -6.0, 7.75)
TCP_OFFSET = (1.0, 2.5, 60.25, 0.25, -0.125, 0.375)
TCP_LOAD = (1.5, 10.25, -20.5, 30.125)
GRAVITY = (0.5, -0.25, -0.75)
WORLD = (100.5, -200.25, 5.0, 0.5, -0.25, 0.125)
TOOL_PARAMS = (11.0, 12.5, 13.0, 14.25, 15.0, 16.5)
VOLTS = (48.25, 48.5, 47.75, 48.0, 49.0, 47.5, 48.75)
CURRENTS = (0.5, 1.25, -0.75, 2.0, 0.125, -1.5, 0.0)
SPEEDS = (0.25, -0.5, 0.75, -1.0, 1.25, -1.5, 1.75)
TEMPS = (31, 32, 33, 34, 35, 36, -5)
SERVO = ((1, 10), (2, 20), (3, 30), (4, 40), (5, 50), (6, 60), (7, 70))
IN_FUNCS = tuple(range(1, 17))
OUT_FUNCS = tuple(range(101, 117))


def distinct() -> ReportSnapshot:
    return ReportSnapshot(
        state=2, mode=1, cmdnum=0x1234, joints=JOINTS, pose=POSE, torques=TORQUES,
        brake_bits=0x3F, enable_bits=0x1F, error=24, warning=11, tcp_offset=TCP_OFFSET, tcp_load=TCP_LOAD,
        collision_sensitivity=4, teach_sensitivity=2, gravity_direction=GRAVITY,
        robot_type=5, axis=7, master_id=0xAA, slave_id=0x55, motor_tid=9, motor_fid=8,
        version="7,5,XS1304,AC1303,v1.6.0",
        tcp_jerk=9000.0, tcp_min_acc=2.0, tcp_max_acc=40000.0, tcp_min_speed=0.5, tcp_max_speed=900.0,
        joint_jerk=400.0, joint_min_acc=0.25, joint_max_acc=18.0, joint_min_speed=0.125, joint_max_speed=3.0,
        rot_jerk=2.25, max_rot_acc=2.75, servo_codes=SERVO, tgpio_code=(3, 19), temperatures=TEMPS,
        tcp_speed=123.5, joint_speeds=SPEEDS, counter=0x01020304, world_offset=WORLD,
        cgpio_reset_on_stop=True, tgpio_reset_on_stop=False, simulation=True, self_collision=True,
        collision_tool_type=3, collision_tool_params=TOOL_PARAMS,
        joint_voltages=VOLTS, joint_currents=CURRENTS,
        cgpio_state=0, cgpio_error=0, cgpio_input_function=0x0100, cgpio_input_config=0xFFFD,
        cgpio_output_function=0x0002, cgpio_output_config=0xFF00,
        analog_inputs=(2.5, 7.5), analog_outputs=(10.0, 1.0),
        input_functions=IN_FUNCS, output_functions=OUT_FUNCS,
    )


def at(frame: bytes, byte: int, fmt: str) -> tuple:
    """Unpack ``fmt`` at the manual's 1-based byte number."""
    return struct.unpack_from(fmt, frame, byte - 1)


# --- lengths, header, state byte ---------------------------------------------------------------------


@pytest.mark.parametrize("encode, size", [(encode_develop, 87), (encode_normal, 145), (encode_rich, 433)])
def test_length_and_header(encode, size):
    frame = encode(ReportSnapshot())
    assert len(frame) == size
    assert at(frame, 1, ">I") == (size,)
    assert size != 233  # the SDK's reader breaks on 233 (it keys its layout on the length)
    assert (DEVELOP_SIZE, NORMAL_SIZE, RICH_SIZE) == (87, 145, 433)


def test_state_byte_low_nibble_state_high_nibble_mode():
    frame = encode_develop(ReportSnapshot(state=3, mode=2))
    assert frame[4] == 0x23
    frame = encode_develop(ReportSnapshot(state=1, mode=11))
    assert frame[4] == 0xB1


def test_state_outside_nibble_refused():
    with pytest.raises(ValueError):
        encode_develop(ReportSnapshot(state=16))
    with pytest.raises(ValueError):
        encode_develop(ReportSnapshot(mode=-1))


def test_manual_develop_example_bytes_36_to_59():
    """Section 2.1.6 example: bytes 36..59 of a develop report and their fp32 reading."""
    example = bytes([0x18, 0x00, 0x4F, 0x43, 0x24, 0xFC, 0x8A, 0x28, 0x08, 0x01, 0xE0, 0x42,
                     0xDB, 0x0F, 0x49, 0xC0, 0x00, 0x00, 0x00, 0x24, 0x00, 0x00, 0x00, 0x00])
    values = struct.unpack("<6f", example)
    assert values[0] == 207.0003662109375
    assert values[1] == pytest.approx(1.54304263051859e-14, rel=1e-12)
    assert values[2] == 112.00201416015625
    assert values[4] == pytest.approx(2.7755575615628914e-17, rel=1e-12)
    frame = encode_develop(ReportSnapshot(pose=values))
    assert frame[35:59] == example
    assert decode_develop(frame).pose == values


# --- every field at the manual's offset -------------------------------------------------------------


def test_develop_offsets():
    f = encode_develop(distinct())
    assert f[4] == (1 << 4) | 2
    assert at(f, 6, ">H") == (0x1234,)
    assert at(f, 8, "<7f") == JOINTS
    assert at(f, 36, "<6f") == POSE
    assert at(f, 60, "<7f") == TORQUES


def test_normal_offsets():
    s = distinct()
    f = encode_normal(s)
    assert f[:4] == struct.pack(">I", 145) and f[4:87] == encode_develop(s)[4:87]
    assert at(f, 88, "4B") == (0x3F, 0x1F, 24, 11)
    assert at(f, 92, "<6f") == TCP_OFFSET
    assert at(f, 116, "<4f") == TCP_LOAD
    assert at(f, 132, "2B") == (4, 2)
    assert at(f, 134, "<3f") == GRAVITY


def test_rich_offsets():
    s = distinct()
    f = encode_rich(s)
    assert f[:4] == struct.pack(">I", 433) and f[4:145] == encode_normal(s)[4:145]
    assert at(f, 146, "6B") == (5, 7, 0xAA, 0x55, 9, 8)
    assert at(f, 152, "30s")[0] == b"7,5,XS1304,AC1303,v1.6.0".ljust(30, b"\0")
    assert at(f, 182, "<5f") == (9000.0, 2.0, 40000.0, 0.5, 900.0)
    assert at(f, 202, "<5f") == (400.0, 0.25, 18.0, 0.125, 3.0)
    assert at(f, 222, "<2f") == (2.25, 2.75)
    assert at(f, 230, "14B") == tuple(c for pair in SERVO for c in pair)
    assert at(f, 244, "2B") == (3, 19)
    assert at(f, 246, "7b") == TEMPS
    assert at(f, 253, "<f") == (123.5,)
    assert at(f, 257, "<7f") == SPEEDS
    assert at(f, 285, ">I") == (0x01020304,)
    assert at(f, 289, "<6f") == WORLD
    assert at(f, 313, "5B") == (1, 0, 1, 1, 3)
    assert at(f, 318, "<6f") == TOOL_PARAMS
    assert at(f, 342, ">7H") == tuple(round(v * 100) for v in VOLTS)
    assert at(f, 356, "<7f") == CURRENTS
    assert at(f, 384, "2B") == (0, 0)
    assert at(f, 386, ">4H") == (0x0100, 0xFFFD, 0x0002, 0xFF00)
    # analog values: 12-bit counts, 4095 = 10 V
    assert at(f, 394, ">4H") == (1024, 3071, 4095, 410)
    assert at(f, 402, "8B") == IN_FUNCS[:8]
    assert at(f, 410, "8B") == OUT_FUNCS[:8]
    assert at(f, 418, "8B") == IN_FUNCS[8:]
    assert at(f, 426, "8B") == OUT_FUNCS[8:]


def test_long_version_is_cut_to_30_bytes():
    f = encode_rich(ReportSnapshot(version="x" * 40))
    assert at(f, 152, "30s")[0] == b"x" * 30
    assert f[181:185] == struct.pack("<f", ReportSnapshot().tcp_jerk)


def test_short_joint_vectors_are_padded_to_seven():
    s = ReportSnapshot(joints=JOINTS[:6], torques=TORQUES[:5], temperatures=(40,) * 6,
                       joint_speeds=SPEEDS[:6], joint_voltages=VOLTS[:6], joint_currents=CURRENTS[:6])
    f = encode_rich(s)
    assert at(f, 8, "<7f") == JOINTS[:6] + (0.0,)
    assert at(f, 60, "<7f") == TORQUES[:5] + (0.0, 0.0)
    assert at(f, 246, "7b") == (40,) * 6 + (0,)
    assert at(f, 257, "<7f") == SPEEDS[:6] + (0.0,)
    assert at(f, 342, ">7H")[6] == 0
    assert at(f, 356, "<7f") == CURRENTS[:6] + (0.0,)


def test_out_of_range_voltage_and_analog_are_clamped():
    s = ReportSnapshot(joint_voltages=(-3.0, 1e6, math.nan, 0, 0, 0, 0), analog_inputs=(-1.0, 20.0))
    f = encode_rich(s)
    assert at(f, 342, ">3H") == (0, 0xFFFF, 0)
    assert at(f, 394, ">2H") == (0, 8190)


# --- decoding ------------------------------------------------------------------------------------------


def test_round_trip_all_reports():
    s = distinct()
    d = decode_rich(encode_rich(s))
    expect = replace(s, analog_inputs=d.analog_inputs, analog_outputs=d.analog_outputs)
    assert d == expect
    for got, want in zip(d.analog_inputs + d.analog_outputs, s.analog_inputs + s.analog_outputs, strict=True):
        assert abs(got - want) <= 10 / 4095 / 2
    n = decode_normal(encode_normal(s))
    assert (n.state, n.mode, n.cmdnum, n.joints, n.pose, n.torques) == (2, 1, 0x1234, JOINTS, POSE, TORQUES)
    assert (n.brake_bits, n.enable_bits, n.error, n.warning) == (0x3F, 0x1F, 24, 11)
    assert (n.tcp_offset, n.tcp_load, n.gravity_direction) == (TCP_OFFSET, TCP_LOAD, GRAVITY)
    assert (n.collision_sensitivity, n.teach_sensitivity) == (4, 2)
    assert n.axis == ReportSnapshot().axis  # not in the normal report: default kept
    dv = decode_develop(encode_develop(s))
    assert (dv.state, dv.mode, dv.cmdnum) == (2, 1, 0x1234)
    assert (dv.joints, dv.pose, dv.torques) == (JOINTS, POSE, TORQUES)
    assert dv.error == 0


f32 = st.floats(width=32, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(state=st.integers(0, 15), mode=st.integers(0, 15), cmdnum=st.integers(0, 0xFFFF),
       joints=st.tuples(*[f32] * 7), pose=st.tuples(*[f32] * 6), load=st.tuples(*[f32] * 4),
       err=st.integers(0, 255), counter=st.integers(0, 2**32 - 1), word=st.integers(0, 0xFFFF))
def test_round_trip_property(state, mode, cmdnum, joints, pose, load, err, counter, word):
    s = ReportSnapshot(state=state, mode=mode, cmdnum=cmdnum, joints=joints, pose=pose, tcp_load=load,
                       error=err, counter=counter, cgpio_output_config=word)
    d = decode_rich(encode_rich(s))
    assert (d.state, d.mode, d.cmdnum) == (state, mode, cmdnum)
    assert (d.joints, d.pose, d.tcp_load) == (joints, pose, load)
    assert (d.error, d.counter, d.cgpio_output_config) == (err, counter, word)


def test_decoders_check_length():
    rich = encode_rich(distinct())
    with pytest.raises(ReportError):
        decode_rich(rich[:-1])  # shorter than 433 bytes
    with pytest.raises(ReportError):
        decode_normal(encode_develop(distinct()))
    bad = struct.pack(">I", 150) + encode_normal(distinct())[4:]
    with pytest.raises(ReportError):
        decode_normal(bad)  # length field disagrees with the bytes
    # a longer frame with a matching length field: tail ignored
    longer = struct.pack(">I", 500) + rich[4:] + bytes(500 - 433)
    assert decode_rich(longer) == decode_rich(rich)


def test_port_tables():
    assert R.ENCODERS[30003] is encode_develop and R.ENCODERS[30001] is encode_normal
    assert R.ENCODERS[30002] is encode_rich
    assert R.RATES == {30003: 100.0, 30001: 5.0, 30002: 5.0}
    for port, enc in R.ENCODERS.items():
        assert R.DECODERS[port](enc(distinct())).cmdnum == 0x1234


def test_encode_is_fast():
    """Loose guard against a slow encoder (measured ~1.5 us develop, ~11 us rich)."""
    import time

    s = distinct()
    t0 = time.perf_counter()
    for _ in range(1000):
        encode_develop(s)
    assert (time.perf_counter() - t0) / 1000 < 100e-6


# --- the official SDK reads our frames ---------------------------------------------------------------

xarm = pytest.importorskip("xarm")


class _FakeReportStream:
    """Stands in for the SDK's report socket: connected, counts close() (the SDK's rejection)."""

    connected = True

    def __init__(self) -> None:
        self.closed = 0

    def close(self) -> None:
        self.closed += 1


@pytest.fixture
def sdk_arm():
    from xarm.wrapper import XArmAPI

    api = XArmAPI("127.0.0.1", do_not_open=True, is_radian=True)
    arm = api._arm
    arm._stream_report = _FakeReportStream()
    arm.arm_cmd = SimpleNamespace(has_err_warn=False)  # the parser flags errors on the command channel
    arm._control_box_type_is_1300 = True  # read the 16-input tail (bytes 418..433)
    # as after GET_VERSION from a v1.6.0 box (below 0.2.1 the SDK reads the load CoG in metres)
    arm._major_version_number, arm._minor_version_number, arm._revision_version_number = 1, 6, 0
    return api


def _feed(api, report_type: str, frame: bytes) -> None:
    api._arm._report_type = report_type
    api._arm._handle_report_data(frame)


def _approx(values, tol=1e-6):
    return pytest.approx(list(values), abs=tol)


def test_sdk_structures_read_rich_frame():
    from xarm.x3.report import ReportDataStructure

    s = distinct()
    rd = ReportDataStructure.create(30002, is_radian=True)
    rd.update(encode_rich(s))
    assert (rd.data_size, rd.state, rd.mode, rd.cmd_num) == (433, 2, 1, 0x1234)
    assert rd.actual_joint_angle == list(JOINTS) and rd.actual_tcp_pose == list(POSE)
    assert rd.estimated_joint_torque == list(TORQUES)
    assert (rd.motor_brake_status, rd.motor_enable_status) == (0x3F, 0x1F)
    assert (rd.error_code, rd.warn_code) == (24, 11)
    assert rd.tcp_offset == list(TCP_OFFSET) and rd.tcp_payload == list(TCP_LOAD)
    assert (rd.collision_sens, rd.teaching_sens) == (4, 2) and rd.gravity_direction == list(GRAVITY)
    assert (rd.robot_type, rd.robot_axis, rd.master_id, rd.slave_id) == (5, 7, 0xAA, 0x55)
    assert rd.version == s.version
    assert [rd.tcp_jerk, rd.tcp_min_acc, rd.tcp_max_acc, rd.tcp_min_speed, rd.tcp_max_speed] == \
        [9000.0, 2.0, 40000.0, 0.5, 900.0]
    assert [rd.joint_jerk, rd.joint_max_acc, rd.joint_max_speed, rd.rot_jerk, rd.rot_max_acc] == \
        [400.0, 18.0, 3.0, 2.25, 2.75]
    assert rd.servo_status_codes == list(SERVO) and rd.tgpio_status_codes == [3, 19]
    assert rd.temperatures == list(TEMPS)
    assert rd.target_tcp_speed == 123.5 and rd.target_joint_speed == list(SPEEDS)
    assert rd.counter == 0x01020304 and rd.world_offset == list(WORLD)
    assert (rd.cgpio_reset_enable, rd.tgpio_reset_enable, rd.is_simulation_robot) == (1, 0, True)
    assert rd.is_collision_detection and rd.collision_tool_type == 3
    assert rd.collision_tool_params == list(TOOL_PARAMS)
    assert rd.joint_voltages == [round(v * 100) for v in VOLTS] and rd.joint_currents == list(CURRENTS)
    assert rd.cgpio_analog_input == _approx((2.5, 7.5), 10 / 4095 / 2)
    assert rd.cgpio_analog_output == _approx((10.0, 1.0), 10 / 4095 / 2)
    assert rd.cgpio_digital_input_io_config == list(IN_FUNCS)
    assert rd.cgpio_digital_output_io_config == list(OUT_FUNCS)


@pytest.mark.parametrize("port, encode", [(30001, encode_normal), (30003, encode_develop)])
def test_sdk_structures_read_normal_and_develop(port, encode):
    from xarm.x3.report import ReportDataStructure

    rd = ReportDataStructure.create(port, is_radian=True)
    rd.update(encode(distinct()))
    assert (rd.state, rd.mode, rd.cmd_num) == (2, 1, 0x1234)
    assert rd.actual_joint_angle == list(JOINTS) and rd.actual_tcp_pose == list(POSE)
    assert rd.estimated_joint_torque == list(TORQUES)
    if port == 30001:
        assert (rd.error_code, rd.warn_code, rd.collision_sens, rd.teaching_sens) == (24, 11, 4, 2)
        assert rd.tcp_offset == list(TCP_OFFSET) and rd.gravity_direction == list(GRAVITY)


def test_sdk_parses_rich_report(sdk_arm):
    api = sdk_arm
    _feed(api, "rich", encode_rich(distinct()))
    assert api._arm._stream_report.closed == 0  # the SDK did not reject the frame
    assert (api.state, api.mode, api.cmd_num) == (2, 1, 0x1234)
    assert api.angles == list(JOINTS)
    assert api.position == list(POSE)
    assert api.joints_torque == list(TORQUES)
    assert (api.error_code, api.warn_code) == (24, 11)
    assert api.tcp_offset == list(TCP_OFFSET)
    assert api.tcp_load == [TCP_LOAD[0], list(TCP_LOAD[1:])]
    assert (api.collision_sensitivity, api.teach_sensitivity) == (4, 2)
    assert api.gravity_direction == list(GRAVITY)
    assert (api.axis, api.device_type, api.master_id, api.slave_id) == (7, 5, 0xAA, 0x55)
    assert api.motor_brake_states[:6] == [1] * 6 and api.motor_enable_states[:6] == [1] * 5 + [0]
    assert api.tcp_jerk == 9000.0 and api.tcp_speed_limit == [0.5, 900.0]
    assert api.tcp_acc_limit == [2.0, 40000.0]
    assert api.joint_jerk == 400.0 and api.joint_speed_limit == [0.125, 3.0]
    assert api.joint_acc_limit == [0.25, 18.0]
    assert [list(c) for c in api.servo_codes[:7]] == [list(c) for c in SERVO]
    assert api.temperatures == list(TEMPS)
    assert api.realtime_tcp_speed == 123.5 and api.realtime_joint_speeds == list(SPEEDS)
    assert api.count == 0x01020304
    assert api.world_offset == _approx(WORLD)
    assert api._arm._cgpio_reset_enable == 1 and api._arm._tgpio_reset_enable == 0
    assert api.is_simulation_robot is True
    assert api.self_collision_params == [1, 3, list(TOOL_PARAMS)]
    assert api.voltages == _approx(VOLTS) and api.currents == list(CURRENTS)
    cg = api.cgpio_states
    assert cg[:6] == [0, 0, 0x0100, 0xFFFD, 0x0002, 0xFF00]
    assert cg[6:10] == _approx((2.5, 7.5, 10.0, 1.0), 10 / 4095 / 2)
    assert cg[10] == list(IN_FUNCS) and cg[11] == list(OUT_FUNCS)


def test_sdk_parses_default_snapshot(sdk_arm):
    api = sdk_arm
    _feed(api, "rich", encode_rich(ReportSnapshot()))
    assert api._arm._stream_report.closed == 0
    assert (api.state, api.axis, api.device_type) == (4, 6, 6)
    assert api.gravity_direction == [0.0, 0.0, -1.0]


def test_sdk_parses_normal_report(sdk_arm):
    api = sdk_arm
    _feed(api, "normal", encode_normal(distinct()))
    assert api._arm._stream_report.closed == 0
    assert (api.state, api.mode, api.cmd_num, api.error_code, api.warn_code) == (2, 1, 0x1234, 24, 11)
    assert api.angles == list(JOINTS) and api.position == list(POSE)
    assert api.tcp_offset == list(TCP_OFFSET) and api.tcp_load == [TCP_LOAD[0], list(TCP_LOAD[1:])]
    assert (api.collision_sensitivity, api.teach_sensitivity) == (4, 2)
    assert api.gravity_direction == list(GRAVITY)


def test_sdk_parses_develop_report(sdk_arm):
    api = sdk_arm
    _feed(api, "real", encode_develop(distinct()))
    assert (api.state, api.mode, api.cmd_num) == (2, 1, 0x1234)
    assert api.angles == list(JOINTS) and api.position == list(POSE) and api.joints_torque == list(TORQUES)


@pytest.mark.parametrize("field, value", [("collision_sensitivity", 6), ("teach_sensitivity", 7),
                                          ("mode", 12), ("state", 10)])
def test_sdk_rejects_values_outside_its_ranges(sdk_arm, field, value):
    """Negative control: the fake stream does see the SDK's rejection (it closes the report socket)."""
    api = sdk_arm
    _feed(api, "rich", encode_rich(replace(distinct(), **{field: value})))
    assert api._arm._stream_report.closed == 1


# --- firmware 2.x: the rich, develop and real-time reports read by the SDK as from a 2.7.1 box ---------

FT_EXT = (1.5, -2.5, 3.25, 0.125, -0.25, 0.5)
FT_RAW = (10.5, -20.5, 30.25, 1.125, -1.25, 1.5)
AA = (3.0, -0.25, 0.75)
BOUNDARY = (500, -400, 300, -200, 600, -50)
RANGES = tuple((-1.0 - i / 4, 1.0 + i / 4) for i in range(7))
FLAT_RANGES = tuple(x for pair in RANGES for x in pair)


def snapshot() -> ReportSnapshot:
    return ReportSnapshot(
        state=2, mode=1, cmdnum=0x1234, joints=JOINTS, pose=POSE, counter=0x01020304, error=0,
        ft_ext_force=FT_EXT, ft_raw_force=FT_RAW, iden_progress=42, pose_aa=AA,
        report_current=True, approx_motion=True, cart_continuous=False,
        reduced_mode=True, reduced_tcp_boundary=BOUNDARY, reduced_max_tcp_speed=250.5,
        reduced_max_joint_speed=1.25, reduced_joint_ranges=FLAT_RANGES, fence=True, collision_rebound=True,
        cgpio_alarm=0x0A0B0C0D, ft_enabled=True, monitor_device_type=3, monitor_device_state=1,
        monitor_device_values=(-120, 45, 7),
    )


@pytest.fixture
def sdk_arm_fw2():
    """The SDK's parser as after GET_VERSION from a 2.7.1 box (the 2.x report tails)."""
    from xarm.wrapper import XArmAPI

    api = XArmAPI("127.0.0.1", do_not_open=True, is_radian=True)
    arm = api._arm
    arm._stream_report = _FakeReportStream()
    arm.arm_cmd = SimpleNamespace(has_err_warn=False)
    arm._control_box_type_is_1300 = True
    arm._major_version_number, arm._minor_version_number, arm._revision_version_number = 2, 7, 1
    return api


def test_rich2_layout_offsets():
    frame = R.encode_rich2(snapshot())
    assert len(frame) == 587 and struct.unpack_from(">I", frame, 0) == (587,)
    assert frame[:433][4:] == R.encode_rich(snapshot())[4:]  # the manual's part is unchanged
    assert struct.unpack_from("<6f", frame, 433) == FT_EXT
    assert struct.unpack_from("<6f", frame, 457) == FT_RAW
    assert frame[481] == 42 and struct.unpack_from("<3f", frame, 482) == AA
    assert frame[494] == 0b01111  # reduced, fence, report current, approx motion; not continuous
    assert frame[495] == 1 and struct.unpack_from(">6h", frame, 496) == BOUNDARY
    assert struct.unpack_from("<2f", frame, 508) == (250.5, 1.25)
    assert struct.unpack_from("<14f", frame, 516) == FLAT_RANGES
    assert (frame[572], frame[573]) == (1, 1)
    assert struct.unpack_from(">I", frame, 574) == (0x0A0B0C0D,)
    assert frame[578] == 1 and (frame[579], frame[580]) == (3, 1)
    assert struct.unpack_from(">3h", frame, 581) == (-120, 45, 7)


def test_rich2_round_trip():
    s = snapshot()
    d = R.decode_rich2(R.encode_rich2(s))
    for name in ("ft_ext_force", "ft_raw_force", "pose_aa", "reduced_tcp_boundary", "reduced_joint_ranges",
                 "monitor_device_values"):
        assert tuple(getattr(d, name)) == tuple(getattr(s, name)), name
    assert (d.iden_progress, d.reduced_mode, d.fence, d.collision_rebound, d.cgpio_alarm, d.ft_enabled) == \
        (42, True, True, True, 0x0A0B0C0D, True)
    assert (d.report_current, d.approx_motion, d.cart_continuous) == (True, True, False)
    assert (d.reduced_max_tcp_speed, d.reduced_max_joint_speed) == (250.5, 1.25)
    assert (d.state, d.mode, d.cmdnum, tuple(d.joints), d.counter) == (2, 1, 0x1234, JOINTS, 0x01020304)


def test_sdk_parses_rich2(sdk_arm_fw2):
    arm = sdk_arm_fw2._arm
    arm._report_type = "rich"
    arm._handle_report_data(R.encode_rich2(snapshot()))
    assert arm._stream_report.closed == 0
    assert (sdk_arm_fw2.state, sdk_arm_fw2.mode, sdk_arm_fw2.cmd_num) == (2, 1, 0x1234)
    assert sdk_arm_fw2.angles == list(JOINTS) and sdk_arm_fw2.position == list(POSE)
    assert sdk_arm_fw2.error_code == 0 and arm.count == 0x01020304
    assert arm.ft_ext_force == list(FT_EXT) and arm.ft_raw_force == list(FT_RAW)
    assert arm.position_aa == [*POSE[:3], *AA]
    assert arm.is_reduced_mode and arm.is_fence_mode and arm.is_collision_rebound
    assert arm.is_report_current and arm.is_approx_motion and not arm.is_cart_continuous
    assert list(arm.reduced_tcp_boundary) == list(BOUNDARY)
    assert arm.reduced_max_tcp_speed == 250.5 and arm.reduced_max_joint_speed == 1.25
    assert [tuple(p) for p in arm.reduced_joint_limits] == list(RANGES)
    assert arm.cgpio_alarm_code == 0x0A0B0C0D and arm.ft_sensor_is_enable
    assert (arm.monitor_device_type, arm.monitor_device_state) == (3, 1)
    assert (arm.monitor_device_pos, arm.monitor_device_speed, arm.monitor_device_current) == (-120, 45, 7)


def test_develop2_layout_and_sdk():
    from xarm.x3.report import ReportDataStructure

    frame = R.encode_develop2(snapshot())
    assert len(frame) == 135 and struct.unpack_from(">I", frame, 0) == (135,)
    assert struct.unpack_from("<6f6f", frame, 87) == FT_EXT + FT_RAW
    rd = ReportDataStructure.create(30003, is_radian=True)
    rd.update(frame)
    assert (rd.state, rd.mode, rd.cmd_num) == (2, 1, 0x1234)
    assert rd.actual_joint_angle == list(JOINTS) and rd.actual_tcp_pose == list(POSE)
    d = R.decode_develop2(frame)
    assert tuple(d.ft_ext_force) == FT_EXT and tuple(d.ft_raw_force) == FT_RAW


def test_sdk_real_parser_reads_develop2_ft(sdk_arm_fw2):
    arm = sdk_arm_fw2._arm
    arm._report_type = "real"
    arm._handle_report_data(R.encode_develop2(snapshot()))
    assert sdk_arm_fw2.angles == list(JOINTS) and sdk_arm_fw2.position == list(POSE)
    assert arm.ft_ext_force == list(FT_EXT) and arm.ft_raw_force == list(FT_RAW)


def test_realtime_report_through_sdk_structure():
    from xarm.x3.report import ReportDataStructure

    s = replace(snapshot(), timestamp_us=123456789012, joint_speeds=(0.25,) * 7,
                tcp_velocity=(1.0, 2.0, 3.0, 0.5, 0.25, 0.125), analog_inputs=(2.5, 7.5),
                analog_outputs=(1.0, 0.0), cgpio_input_config=0x00F0, cgpio_output_config=0x0003)
    frame = R.encode_realtime(s)
    assert len(frame) == 804
    rd = ReportDataStructure.create(30000, is_radian=True)
    rd.update(frame)
    assert (rd.data_size, rd.state, rd.mode, rd.cmd_num) == (804, 2, 1, 0x1234)
    assert rd.timestamp == 123456789012
    assert rd.actual_joint_angle == list(JOINTS) and rd.target_joint_angle == list(JOINTS)
    assert rd.actual_joint_velocity == [0.25] * 7
    assert rd.actual_tcp_pose == [*POSE[:3], *AA]
    assert rd.ft_raw_force == list(FT_RAW) and rd.ft_ext_force == list(FT_EXT)
    assert (rd.monitor_device_type, rd.monitor_device_state) == (3, 1)
    assert rd.cgpio_digital_input == 0x00F0 and rd.cgpio_digital_output == 0x0003
    assert rd.cgpio_analog_input == [2500, 7500]
    d = R.decode_realtime(frame)
    assert (d.timestamp_us, d.state, d.cmdnum, tuple(d.joints), tuple(d.pose_aa)) == \
        (123456789012, 2, 0x1234, JOINTS, AA)


def test_realtime_columns_read_what_decode_realtime_reads():
    """The offsets for reading many real-time frames at once give each field of decode_realtime."""
    s = replace(snapshot(), timestamp_us=987654321, joint_speeds=tuple(0.1 * i for i in range(7)),
                joint_currents=tuple(-0.5 * i for i in range(7)), torques=tuple(1.5 + i for i in range(7)))
    frame = R.encode_realtime(s)
    d = R.decode_realtime(frame)
    read = {name: struct.unpack_from(fmt[0] + fmt[1:] * n, frame, off)
            for name, (off, fmt, n) in R.REALTIME_COLUMNS.items()}
    assert read["timestamp_us"] == (d.timestamp_us,)
    assert read["state_mode"] == (d.state | d.mode << 4,)
    assert read["joints"] == tuple(d.joints) and read["joint_speeds"] == tuple(d.joint_speeds)
    assert read["joint_currents"] == tuple(d.joint_currents) and read["torques"] == tuple(d.torques)
    assert read["position"] == tuple(d.pose[:3])


def test_encoders_by_profile():
    v1 = R.encoders_for(DEFAULT_PROFILE)
    assert {p: len(enc(ReportSnapshot())) for p, enc in v1.items()} == {30003: 87, 30001: 145, 30002: 433}
    v2 = R.encoders_for(FirmwareProfile.for_version("2.7.1"))
    assert {p: len(enc(ReportSnapshot())) for p, enc in v2.items()} == \
        {30003: 135, 30001: 145, 30002: 587, 30000: 804}
    for port, dec in R.decoders_for(FirmwareProfile.for_version("2.7.1")).items():
        assert dec(v2[port](snapshot())).cmdnum == 0x1234
    assert R.rates_for(FirmwareProfile.for_version("2.7.1"))[30000] == 250.0
    assert 30000 not in R.rates_for(DEFAULT_PROFILE)


def test_v1_decoder_reads_the_manual_part_of_a_2x_frame():
    s = snapshot()
    assert R.decode_rich(R.encode_rich2(s)) == R.decode_rich(R.encode_rich(s))


@pytest.mark.parametrize("decode, size", [(R.decode_rich2, 587), (R.decode_develop2, 135),
                                          (R.decode_realtime, 804)])
def test_short_or_mislabelled_frames_refused(decode, size):
    with pytest.raises(ReportError):
        decode(b"\0" * (size - 1))
    bad = bytearray(size)
    struct.pack_into(">I", bad, 0, size + 1)
    with pytest.raises(ReportError):
        decode(bytes(bad))


def test_out_of_range_tail_values_do_not_crash():
    s = replace(snapshot(), reduced_tcp_boundary=(1e9, -1e9, float("nan"), 0, 0, 0),
                monitor_device_values=(70000, -70000, float("inf")))
    d = R.decode_rich2(R.encode_rich2(s))
    assert tuple(d.reduced_tcp_boundary) == (32767, -32768, 0, 0, 0, 0)
    assert tuple(d.monitor_device_values) == (32767, -32768, 0)
