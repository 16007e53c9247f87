"""Firmware 2.x report frames: the 587-byte rich report, the 135-byte develop report and the
804-byte real-time report of port 30000, read back through the SDK's own parsers.

Offsets are the SDK's 0-based reading of the 2.x tails; the manual V1.6.0 stops at 433 bytes.
"""

from __future__ import annotations

import struct
from dataclasses import replace
from types import SimpleNamespace

import pytest

from xarm_emu.protocol import reports as R
from xarm_emu.protocol.firmware import DEFAULT_PROFILE, FirmwareProfile
from xarm_emu.protocol.reports import ReportError, ReportSnapshot

JOINTS = (0.5, -1.25, 2.0, -0.75, 1.125, -2.5, 0.0625)
POSE = (207.5, -101.25, 112.0, 3.140625, -0.5, 1.5)
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


class _FakeReportStream:
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


def test_sdk_parses_rich2(sdk_arm):
    arm = sdk_arm._arm
    arm._report_type = "rich"
    arm._handle_report_data(R.encode_rich2(snapshot()))
    assert arm._stream_report.closed == 0
    assert (sdk_arm.state, sdk_arm.mode, sdk_arm.cmd_num) == (2, 1, 0x1234)
    assert sdk_arm.angles == list(JOINTS) and sdk_arm.position == list(POSE)
    assert sdk_arm.error_code == 0 and arm.count == 0x01020304
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


def test_sdk_real_parser_reads_develop2_ft(sdk_arm):
    arm = sdk_arm._arm
    arm._report_type = "real"
    arm._handle_report_data(R.encode_develop2(snapshot()))
    assert sdk_arm.angles == list(JOINTS) and sdk_arm.position == list(POSE)
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
