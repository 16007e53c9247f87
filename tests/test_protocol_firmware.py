"""Firmware profiles and the register table by profile (manual section 2.1.3; what the SDK sends
for a 2.x claim, built with the SDK's own request encoders over a fake port)."""

from __future__ import annotations

import math
import struct

import pytest

from xarm_emu.protocol import registers as R
from xarm_emu.protocol.firmware import (
    DEFAULT_PROFILE,
    NEWEST_PROFILE,
    SUPPORTED_VERSIONS,
    FirmwareProfile,
    FirmwareVersion,
    VersionError,
    parse_version,
    profile_for,
)
from xarm_emu.protocol.frame import decode_request, encode_reply
from xarm_emu.protocol.layouts import LayoutError

V2 = FirmwareProfile.for_version("2.7.1")
INF = math.inf


# ---- versions ------------------------------------------------------------------------------------


@pytest.mark.parametrize("text, parts", [("1.6.0", (1, 6, 0)), ("v2.4.101", (2, 4, 101)),
                                         ("V2.7.1", (2, 7, 1)), (" 2.0.102 ", (2, 0, 102))])
def test_parse_version(text, parts):
    assert parse_version(text).parts == parts


@pytest.mark.parametrize("text", ["", "2.7", "2.7.1.4", "x2.7.1", "10.1.0", "2.a.1", "-1.0.0"])
def test_bad_version_text_refused(text):
    with pytest.raises(VersionError):
        parse_version(text)


def test_versions_compare_as_integer_tuples():
    v = parse_version
    assert v("2.7.1") < v("2.7.100") and v("2.7.1") >= v("2.6.109") and v("2.4.0") < v("2.4.101")
    assert sorted(map(v, ["2.7.100", "1.6.0", "2.7.1", "1.11.100", "1.8.6"])) == \
        [v("1.6.0"), v("1.8.6"), v("1.11.100"), v("2.7.1"), v("2.7.100")]
    assert str(v("v2.4.101")) == "2.4.101" and v("2.4.101") == FirmwareVersion(2, 4, 101)


def test_default_profile_is_the_manual():
    p = DEFAULT_PROFILE
    assert str(p) == "1.6.0" and not p.reports_2x and p.play_traj_speed
    assert not (p.feedback or p.common_move_layout or p.inf_unchanged or p.io_sync_byte or p.realtime_report
                or p.online_modes or p.velocity_duration)
    assert p.ft_data_register == 150


@pytest.mark.parametrize("version, on", [
    # the SDK's own thresholds (version_is_ge) and the firmware its API documents for a call
    ("1.2.11", {"play_traj_speed"}), ("1.8.0", {"velocity_duration"}), ("1.11.100", {"common_move_layout"}),
    ("2.0.0", {"reports_2x", "online_modes"}), ("2.0.102", {"feedback"}), ("2.1.0", {"realtime_report"}),
    ("2.4.101", {"inf_unchanged", "io_sync_byte"}),
])
def test_thresholds(version, on):
    p = FirmwareProfile.for_version(version)
    v = p.version
    below = FirmwareProfile(FirmwareVersion(v.major, v.minor, v.revision - 1) if v.revision else
                            FirmwareVersion(v.major, v.minor - 1, 999) if v.minor else
                            FirmwareVersion(v.major - 1, 99, 999))
    for name in on:
        assert getattr(p, name) is True and getattr(below, name) is False, name


def test_ft_data_register_follows_the_sensors_registers():
    assert FirmwareProfile.for_version("1.8.2").ft_data_register == 150
    assert FirmwareProfile.for_version("1.8.3").ft_data_register == 200


def test_2x_profile_facts():
    assert V2.ft_data_register == 200 and V2.realtime_report and V2.reports_2x and V2.online_modes


def test_version_text():
    from xarm_emu.controller.controller import version_string
    from xarm_emu.model.robots import XARM6

    text = version_string(XARM6, "XI1304", "AC1304", V2)
    assert text == "6,6,XI1304,AC1304,v2.7.1"
    # the SDK's own register-1 pattern reads the same parts back
    import re
    m = re.match(r".*(\d+),(\d+),(.*),(.*),.*[vV]*(\d+)\.(\d+)\.(\d+).*", text)
    assert m is not None and m.groups() == ("6", "6", "XI1304", "AC1304", "2", "7", "1")
    assert len(text.encode()) <= R.REGISTERS[1].reply.size


def test_cli_versions():
    assert SUPPORTED_VERSIONS[0] == "1.6.0" and str(NEWEST_PROFILE) == SUPPORTED_VERSIONS[-1]
    assert profile_for("v2.7.1") == V2
    with pytest.raises(VersionError, match="not supported"):
        profile_for("2.5.0")


# ---- register table by profile ---------------------------------------------------------------------


def test_v160_table_is_todays():
    assert dict(R.registers_for(DEFAULT_PROFILE)) == R.REGISTERS
    assert R.float_checked(R.registers_for(DEFAULT_PROFILE)) == R.FLOAT_CHECKED
    assert R.inf_unchanged(R.registers_for(DEFAULT_PROFILE)) == frozenset()


def test_registers_appear_with_their_version():
    def t(version):
        return R.registers_for(FirmwareProfile.for_version(version) if isinstance(version, str) else version)

    assert 83 not in t("1.8.99") and 83 in t("1.8.100")
    assert 254 not in t("2.0.101") and 254 in t(V2) and 253 in t(V2)
    assert 232 in t(V2) and 232 not in t("2.2.0")
    for code, reg in t(NEWEST_PROFILE).items():
        assert NEWEST_PROFILE.version.at_least(reg.since), code


def test_table_is_read_only():
    with pytest.raises(TypeError):
        R.registers_for(V2)[999] = R.REGISTERS[1]  # type: ignore[index]


def test_inf_unchanged_registers():
    assert R.inf_unchanged(R.registers_for(V2)) == {21, 23, 83}
    assert R.inf_unchanged(R.registers_for(FirmwareProfile.for_version("2.4.100"))) == frozenset()
    # +inf registers are still float checked: the controller exempts only +inf in them
    assert {21, 23, 83} <= R.float_checked(R.registers_for(V2))


def _sdk_register_codes() -> dict[int, str]:
    from xarm.core.config.x_config import XCONF

    reg = XCONF.UxbusReg
    return {v: k for k, v in vars(reg).items() if k.isupper() and isinstance(v, int)}


#: Codes the SDK names but never sends (their wrappers are commented out).
NEVER_SENT = {54, 56, 57}


def test_every_sdk_register_is_in_the_newest_table():
    sdk = _sdk_register_codes()
    table = R.registers_for(NEWEST_PROFILE)
    missing = {c: n for c, n in sdk.items() if c not in table and c not in NEVER_SENT}
    assert missing == {}
    for code, name in sdk.items():
        if code in table and name != "SET_FENCE_ON":
            assert table[code].name == name, code


# ---- what the SDK sends, decoded through the 2.x table ---------------------------------------------


class _FakePort:
    """Stands in for the SDK's command socket: keeps requests, answers with zero parameters of the
    reply size the table gives (or ``reply_size``)."""

    def __init__(self, table, reply_size: int | None = None) -> None:
        self.table = table
        self.sent: list[bytes] = []
        self.reply_size = reply_size
        self._pending: bytes | None = None

    def flush(self) -> None:
        pass

    def write(self, data: bytes) -> int:
        self.sent.append(bytes(data))
        req = decode_request(bytes(data))
        n = self.reply_size if self.reply_size is not None else self.table[req.register].reply.size
        self._pending = encode_reply(req.tid, req.protocol, req.register, 0, b"\0" * n)
        return 0

    def read(self, timeout: float = 0):
        out, self._pending = self._pending, None
        return -1 if out is None else out


@pytest.fixture
def sdk_cmd():
    from xarm.core.wrapper.uxbus_cmd_tcp import UxbusCmdTcp

    port = _FakePort(R.registers_for(V2))
    cmd = UxbusCmdTcp(port)
    cmd.set_protocol_identifier(3)
    return cmd, port


def _decoded(port: _FakePort, table=None):
    req = decode_request(port.sent[-1])
    reg = (table or port.table)[req.register]
    return req, reg.request.decode(req.params)


def test_sdk_move_line_common(sdk_cmd):
    cmd, port = sdk_cmd
    cmd.move_line_common([300, INF, 200, INF, INF, INF], 100, 2000, 0, radius=-1)
    req, v = _decoded(port)
    assert req.protocol == 3 and req.register == 21 and len(req.params) == 43
    assert v["pose"] == (300.0, INF, 200.0, INF, INF, INF) and (v["speed"], v["acc"], v["radius"]) == \
        (100.0, 2000.0, -1.0)
    assert (v["coord"], v["is_axis_angle"], v["only_check_type"]) == (0, 0, 0) and "motion_type" not in v
    cmd.move_line_common([1, 2, 3, 0, 0, 0], 10, 10, 0, radius=5, coord=1, is_axis_angle=True,
                         only_check_type=1, motion_type=2)
    req, v = _decoded(port)
    assert len(req.params) == 44 and (v["coord"], v["is_axis_angle"], v["only_check_type"],
                                      v["motion_type"]) == (1, 1, 1, 2)


def test_sdk_move_line_common_hex_example():
    # set_position(x=300, z=200, speed=100) on a 2.x claim: y, roll, pitch, yaw unspecified (+inf)
    params = bytes.fromhex("00009643 0000807f 00004843 0000807f 0000807f 0000807f 0000c842 0000fa44 "
                           "00000000 000080bf 000000".replace(" ", ""))
    v = R.registers_for(V2)[21].request.decode(params)
    assert v["pose"] == (300.0, INF, 200.0, INF, INF, INF) and v["acc"] == 2000.0 and v["radius"] == -1.0
    with pytest.raises(LayoutError):
        R.REGISTERS[21].request.decode(params)  # a 1.6.0 box knows only the 36-byte form


def test_sdk_move_relative(sdk_cmd):
    cmd, port = sdk_cmd
    cmd.move_relative([10, 0, 0, 0, 0, 0], 100, 2000, 0, -1)
    req, v = _decoded(port)
    assert req.register == 83 and len(req.params) == 46
    assert v["deltas"] == (10.0,) + (0.0,) * 6 and (v["is_joint_motion"], v["is_axis_angle"]) == (0, 0)
    cmd.move_relative([0.1] * 7, 1, 1, 0, -1, is_joint_motion=True, only_check_type=2, motion_type=1)
    req, v = _decoded(port)
    assert len(req.params) == 48 and (v["is_joint_motion"], v["only_check_type"], v["motion_type"]) == \
        (1, 2, 1)


def test_sdk_move_circle_common_and_checks(sdk_cmd):
    cmd, port = sdk_cmd
    cmd.move_circle_common([1] * 6, [2] * 6, 10, 100, 0, 50, coord=0, is_axis_angle=False, only_check_type=0)
    req, v = _decoded(port)
    assert req.register == 27 and len(req.params) == 67 and v["percent"] == 50.0
    cmd.move_joint([0.1] * 7, 1, 2, 0, only_check_type=1)
    req, v = _decoded(port)
    assert req.register == 23 and len(req.params) == 41 and v["only_check_type"] == 1
    cmd.move_gohome(1, 2, 0, only_check_type=3)
    req, v = _decoded(port)
    assert req.register == 25 and len(req.params) == 13 and v["only_check_type"] == 3


def test_check_reply_is_three_bytes():
    t = R.registers_for(V2)
    for code in (21, 23, 24, 25, 27, 83):
        assert t[code].reply.size == 3 and t[code].reply.decode(b"\x00\x05\x01") == \
            {"cmdnum": 5, "check_result": 1}
        assert t[code].reply.decode(b"\x00\x05") == {"cmdnum": 5}


def test_sdk_velocity_feedback_and_ft(sdk_cmd):
    cmd, port = sdk_cmd
    cmd.vc_set_jointv([0.1, 0, 0, 0, 0, 0, 0], 1, duration=0.5)
    req, v = _decoded(port)
    assert req.params.hex() == "cdcccc3d" + "00000000" * 6 + "01" + "0000003f"
    assert v["speeds"][1:] == (0.0,) * 6 and (v["is_sync"], v["duration"]) == (1, 0.5)
    cmd.vc_set_linev([1, 2, 3, 0, 0, 0], 1, duration=-1)
    req, v = _decoded(port)
    assert len(req.params) == 25 and v["is_tool_coord"] == 1 and "duration" not in v
    cmd.set_feedback_type(2)
    req, v = _decoded(port)
    assert (req.register, v) == (254, {"mask": 2})
    cmd.check_feedback()
    req, v = _decoded(port)
    assert (req.register, req.params) == (253, b"")
    ret = cmd.ft_sensor_get_data(is_new=True, is_raw=True)
    req, v = _decoded(port)
    assert (req.register, v) == (200, {"raw": 1}) and ret[0] == 0 and len(ret) == 7


def test_sdk_ft_config_and_reduced_states_replies(sdk_cmd):
    cmd, port = sdk_cmd
    ret = cmd.ft_sensor_get_config()
    assert decode_request(port.sent[-1]).register == 212 and ret[0] == 0 and len(ret) == 23
    ret = cmd.get_reduced_states(length=79)
    assert decode_request(port.sent[-1]).register == 53 and ret[0] == 0


def test_sdk_admittance_and_force_config(sdk_cmd):
    cmd, port = sdk_cmd
    cmd.set_admittance(1, [1, 0, 1, 0, 0, 0], [0.5] * 6, [1.0] * 6, [2.0] * 6)
    req, v = _decoded(port)
    assert req.register == 207 and v["c_axis"] == (1, 0, 1, 0, 0, 0) and v["K"] == (1.0,) * 6


def test_common_param_layouts():
    assert R.COMMON_PARAM_LAYOUTS[1].decode(struct.pack("<f", 0.5)) == {"factor": 0.5}
    assert R.COMMON_PARAM_LAYOUTS[15].decode(struct.pack("<2i", 3, -1)) == {"params": (3, -1)}
    assert R.COMMON_PARAM_LAYOUTS[26].size == 4
    v = R.registers_for(V2)[232].request.decode(bytes([26, 1, 2, 1, 0]))
    assert v == {"type": 26, "data": bytes([1, 2, 1, 0])}


@pytest.mark.parametrize("code, size", [(21, 35), (21, 45), (83, 45), (27, 66), (254, 2), (200, 2), (212, 1)])
def test_wrong_sizes_are_layout_errors(code, size):
    with pytest.raises(LayoutError):
        R.registers_for(V2)[code].request.decode(b"\0" * size)


@pytest.mark.parametrize("code, hexparams, expect", [
    (127, "090a150080804301", {"host": 9, "addr": 0x0A15, "value": 257.0, "sync": 1}),
    (134, "0000020201", {"digital": 0, "digital_hi": 0x0202, "sync": 1}),
    (135, "07ff01", {"analog": 0x07FF, "sync": 1}),
    (19, "0001", {"mode": 0, "detection_param": 1}),
])
def test_2x_optional_bytes_decode(code, hexparams, expect):
    assert R.registers_for(V2)[code].request.decode(bytes.fromhex(hexparams)) == expect


def test_joint_states_reply_holds_three_blocks():
    reply = R.registers_for(V2)[42].reply
    assert 84 in reply.sizes() and 28 in reply.sizes()
    v = reply.decode(struct.pack("<21f", *range(21)))
    assert v["efforts"] == tuple(float(x) for x in range(14, 21))


def test_protocol_ids():
    from xarm_emu.protocol.frame import Request, answers, decode_reply, reply_for

    assert [answers(p) for p in (0, 1, 2, 3, 4)] == [True, False, True, True, False]
    for prot in (2, 3):
        out = reply_for(Request(7, prot, 13, b""), 0, b"\x02")
        assert out is not None and out.hex() == f"0007000{prot}0003" "0d0002"
        assert decode_reply(out).protocol == prot
    assert reply_for(Request(7, 1, 0, b""), 0) is None


def test_float_rule_exempts_only_plus_inf():
    from xarm_emu.protocol.layouts import all_within

    v = R.registers_for(V2)[21].request.decode(struct.pack("<10f3B", 1, INF, 3, INF, INF, INF, 1, 1, 0, -1,
                                                           0, 0, 0))
    assert not all_within(v, 1e9) and all_within(v, 1e9, inf_unchanged=True)
    for bad in (math.nan, -INF, 2e9):
        assert not all_within({"pose": (bad, INF)}, 1e9, inf_unchanged=True)
