"""The register table: every command of the manual's sections 2.1.3 and 2.1.4.

One entry per register: code, name (the SDK's register name), the manual's
title, request and reply layouts, flags and the manual section. This is the
single home of byte layouts: the controller's dispatcher, the client, the docs
and the tests all read it.

Byte orders (section 2.1.2): fp32 and int32 little-endian, u16 (GPIO words)
big-endian. Replies are the parameters after the state byte.

Where the SDK (claiming firmware v1.6.0) appends optional trailing bytes, the
layout marks them optional with ``required=``; where the manual and the SDK use
different shapes for one register, the layout is a :class:`~.layouts.OneOf`.

:data:`REGISTERS` is what a box of manual V1.6.0 answers. :func:`registers_for` gives the table of
another firmware profile: the registers the SDK sends that the manual lacks
(:data:`EXTRA_REGISTERS`, each with the version it appears in) and the later layouts of 19-27
(:data:`LATER_FORMS`: the "common" 21/27, the only-check byte of 23/24/25 with a 3-byte reply,
+inf as "unchanged" in 21/23/83).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import lru_cache
from types import MappingProxyType
from typing import Any

from .firmware import DEFAULT_VERSION, NEWEST_PROFILE, FirmwareProfile, first
from .layouts import EMPTY, Field, Layout, fp32, i32, one_of, u8, u16


class Flag(enum.Flag):
    NONE = 0
    #: "(System reset)" in the manual: ends motion, clears the buffer, state 5.
    SYSTEM_RESET = enum.auto()
    #: Goes into the command buffer; the reply carries the buffer count (u16).
    QUEUED = enum.auto()
    #: A servo-mode command (mode 1): immediate target, not queued.
    SERVO = enum.auto()
    #: Not in manual V1.6.0, answered because the SDK or ROS driver sends it.
    EXTENSION = enum.auto()
    #: Answers for any float value, NaN and infinities included (a check such as register 45);
    #: other registers refuse such values with warning 12.
    ANY_FLOAT = enum.auto()
    #: +inf in a float field means "keep this component" (firmware >= 2.4.101, registers 21/23/83);
    #: NaN, -inf and finite values beyond the limit are still refused with warning 12.
    INF_UNCHANGED = enum.auto()


@dataclass(frozen=True)
class Register:
    code: int
    name: str
    title: str
    request: Layout = EMPTY
    reply: Layout = EMPTY
    flags: Flag = Flag.NONE
    section: str = "2.1.3.2"
    doc: str = field(default="", compare=False)
    #: The firmware version from which a box answers this register (the manual's: in the manual).
    since: str = DEFAULT_VERSION

    @property
    def system_reset(self) -> bool:
        return bool(self.flags & Flag.SYSTEM_RESET)

    @property
    def queued(self) -> bool:
        return bool(self.flags & Flag.QUEUED)

    @property
    def servo(self) -> bool:
        return bool(self.flags & Flag.SERVO)

    @property
    def extension(self) -> bool:
        return bool(self.flags & Flag.EXTENSION)


#: Reply of queued commands: the number of commands in the buffer (u16 BE).
CMDNUM_REPLY = Layout((u16("cmdnum", "number of commands in the buffer"),))

POSE = fp32("pose", 6, "x, y, z mm; roll, pitch, yaw rad")
POSE_AA = fp32("pose", 6, "x, y, z mm; Rx, Ry, Rz rad (axis-angle)")
JOINTS = fp32("joints", 7, "J1..J7 rad")

_S_IO = "2.1.4"
_QUEUED_DOC = "Reply: buffer count, u16 BE (the SDK reads no reply bytes; longer replies are tolerated)."


def _r(*fields: Field, required: int | None = None) -> Layout:
    return Layout(tuple(fields), required=required)


def _tool_model(n: int) -> Layout:
    """Register 78 with ``n`` fp32 tool parameters ahead of the tool type byte."""
    if n == 0:
        return _r(u8("tool_type"))
    return _r(fp32("params", n), u8("tool_type"))


_TABLE: list[Register] = [
    # ---- 0~10 common port section -------------------------------------------------------------
    Register(1, "GET_VERSION", "Get version information",
             reply=_r(Field("version", "str", 40, "NUL-padded '<axis>,<type>,<robot SN>,<box SN>,vX.Y.Z'")),
             doc="The manual's example reply carries no parameters (length 0x02); the SDK needs the "
                 "40-byte string, so the table follows the SDK."),
    Register(2, "GET_ROBOT_SN", "Get the robot serial number",
             reply=_r(Field("serials", "bytes", 40, "'<robot SN>\\0<control box SN>\\0', NUL-padded")),
             flags=Flag.EXTENSION, section="SDK",
             doc="Sent by the SDK with check_robot_sn; not in manual V1.6.0."),
    Register(5, "GET_REPORT_TAU_OR_I", "Get the value of joint torque or actual current",
             reply=_r(u8("tau_or_i", "0 theoretical joint torque, 1 actual servo current"))),
    Register(8, "GET_KINEMATICS", "Get the kinematics parameters",
             reply=_r(u8("valid"), u8("dof"), u8("robot_type"),
                      fp32("params", 42, "7 x (x, y, z, roll, pitch, yaw) per joint, URDF form")),
             flags=Flag.EXTENSION, section="ROS",
             doc="Read by the ROS driver's kinematics generator; the reply frame is 179 bytes."),
    Register(10, "SYSTEM_CONTROL", "Remotely shut down the operating system",
             request=_r(u8("operation", "1: shut the operating system down")),
             reply=CMDNUM_REPLY,
             doc="The manual's reply shows a u16 parameter; the SDK reads none (longer is tolerated)."),
    # ---- 11~20 system state -------------------------------------------------------------------
    Register(11, "MOTION_EN", "Enable/Disable servo",
             request=_r(u8("joint", "1-7 one joint, 8 all joints"), u8("enable", "1 enable, 0 disable")),
             flags=Flag.SYSTEM_RESET),
    Register(12, "SET_STATE", "Motion state setting",
             request=_r(u8("state", "0 enter motion, 3 suspend, 4 stop"))),
    Register(13, "GET_STATE", "Get the motion state",
             reply=_r(u8("state", "1 moving, 2 sleeping, 3 suspended, 4 stopped, 5 system reset"))),
    Register(14, "GET_CMDNUM", "Get the number of commands in the command buffer", reply=CMDNUM_REPLY),
    Register(15, "GET_ERROR", "Get error and warning code", reply=_r(u8("error"), u8("warning"))),
    Register(16, "CLEAN_ERR", "Clear control box error", flags=Flag.SYSTEM_RESET),
    Register(17, "CLEAN_WAR", "Clear control box warning"),
    Register(18, "SET_BRAKE", "Setting the brake switches separately",
             request=_r(u8("joint", "1-7 one joint, 8 all joints"), u8("enable", "1 brake on, 0 release")),
             flags=Flag.SYSTEM_RESET),
    Register(19, "SET_MODE", "Setting the system motion mode",
             request=_r(u8("mode", "0 position, 1 servo, 2 joint teaching, 3 cartesian teaching"),
                        u8("detection_param"), required=1),
             flags=Flag.SYSTEM_RESET,
             doc="SDKs talking to firmware >= 1.10.0 append a detection parameter byte."),
    # ---- 21~30 basic motion -------------------------------------------------------------------
    Register(21, "MOVE_LINE", "Cartesian linear motion",
             request=_r(POSE, fp32("speed", doc="mm/s"), fp32("acc", doc="mm/s^2"), fp32("mvtime")),
             reply=CMDNUM_REPLY, flags=Flag.QUEUED),
    Register(22, "MOVE_LINEB", "Linear motion with circular arc",
             request=_r(POSE, fp32("speed"), fp32("acc"), fp32("mvtime"), fp32("radius", doc="blend mm")),
             reply=CMDNUM_REPLY, flags=Flag.QUEUED),
    Register(23, "MOVE_JOINT", "P2P joint motion",
             request=_r(JOINTS, fp32("speed", doc="rad/s"), fp32("acc", doc="rad/s^2"), fp32("mvtime")),
             reply=CMDNUM_REPLY, flags=Flag.QUEUED),
    Register(24, "MOVE_JOINTB", "Set joint torque or motor current report",
             request=one_of(
                 _r(u8("tau_or_i", "0 estimated joint torque (Nm), 1 motor current (A)")),
                 _r(JOINTS, fp32("speed"), fp32("acc"), fp32("radius", doc="blend radius, in mvtime's slot")),
             ),
             doc="The manual's form is one byte (torque or current report). The SDK (firmware >= 1.5.20) "
                 "sends a blended joint move here: 7 joints, speed, acc, radius."),
    Register(25, "MOVE_HOME", "Return to zero position",
             request=_r(fp32("speed", doc="rad/s"), fp32("acc", doc="rad/s^2"), fp32("mvtime")),
             reply=CMDNUM_REPLY, flags=Flag.QUEUED),
    Register(26, "SLEEP_INSTT", "Pause commands, command delay",
             request=_r(fp32("seconds")), reply=CMDNUM_REPLY, flags=Flag.QUEUED),
    Register(27, "MOVE_CIRCLE", "Circular motion",
             request=_r(fp32("pose1", 6), fp32("pose2", 6), fp32("speed"), fp32("acc"), fp32("mvtime"),
                        fp32("percent", doc="arc length, % of the circumference")),
             reply=CMDNUM_REPLY, flags=Flag.QUEUED,
             doc="Circle through the current point, pose1 and pose2. The manual lists the percentage "
                 "before speed, acc and mvtime; the SDK sends it last. The table follows the SDK."),
    Register(28, "MOVE_LINE_TOOL", "Linear motion in tool coordinate system",
             request=_r(POSE, fp32("speed"), fp32("acc"), fp32("mvtime")),
             reply=CMDNUM_REPLY, flags=Flag.QUEUED),
    Register(29, "MOVE_SERVOJ", "Servoj motion",
             request=_r(JOINTS, fp32("speed", doc="unused"), fp32("acc", doc="unused"),
                        fp32("mvtime", doc="unused")),
             flags=Flag.SERVO),
    Register(30, "MOVE_SERVO_CART", "Servo cartesian motion",
             request=_r(POSE, fp32("speed", doc="unused"), fp32("acc", doc="unused"),
                        fp32("coord", doc="0 base frame, 1 tool frame (a float)")),
             flags=Flag.SERVO),
    # ---- 31~40 motion parameter setting ------------------------------------------------------
    Register(31, "SET_TCP_JERK", "Set the jerk of the cartesian space translation",
             request=_r(fp32("jerk", doc="mm/s^3")), reply=CMDNUM_REPLY, doc=_QUEUED_DOC),
    Register(32, "SET_TCP_MAXACC", "Set the maximum acceleration of the cartesian space translation",
             request=_r(fp32("maxacc", doc="mm/s^2")), reply=CMDNUM_REPLY, doc=_QUEUED_DOC),
    Register(33, "SET_JOINT_JERK", "Set joint space jerk",
             request=_r(fp32("jerk", doc="rad/s^3")), reply=CMDNUM_REPLY, doc=_QUEUED_DOC),
    Register(34, "SET_JOINT_MAXACC", "Set joint space max acceleration",
             request=_r(fp32("maxacc", doc="rad/s^2")), reply=CMDNUM_REPLY, doc=_QUEUED_DOC),
    Register(35, "SET_TCP_OFFSET", "Set the offset of the robotic arm end-effector",
             request=_r(POSE), flags=Flag.SYSTEM_RESET),
    Register(36, "SET_LOAD_PARAM", "End payload setting",
             request=_r(fp32("mass", doc="kg"), fp32("center", 3, "centre of mass x, y, z mm"))),
    Register(37, "SET_COLLIS_SENS", "Set collision detection sensitivity",
             request=_r(u8("sensitivity", "0-5")), flags=Flag.SYSTEM_RESET),
    Register(38, "SET_TEACH_SENS", "Set teaching sensitivity for teaching mode",
             request=_r(u8("sensitivity", "1-5")), flags=Flag.SYSTEM_RESET),
    Register(39, "CLEAN_CONF", "Delete the current system configuration parameters"),
    Register(40, "SAVE_CONF", "Save the current system configuration parameters"),
    # ---- 41~50 motion information ------------------------------------------------------------
    Register(41, "GET_TCP_POSE", "Get the current cartesian position", reply=_r(POSE)),
    Register(42, "GET_JOINT_POS", "Get the current joint position",
             request=_r(u8("num", "1: real positions; low nibble = how many 7-value blocks"), required=0),
             reply=_r(JOINTS, fp32("velocities", 7), fp32("efforts", 7), required=1),
             doc="The manual's request is empty. SDKs send [num]; the reply then holds num & 0x0F blocks "
                 "of 7 fp32 (positions, velocities, efforts)."),
    Register(43, "GET_IK", "Get the solution of the inverse kinematics",
             request=_r(POSE, u8("limited"), fp32("ref_angles", 7), required=1),
             reply=_r(JOINTS),
             doc="Newer SDKs may append a 'limited' byte and 7 reference angles."),
    Register(44, "GET_FK", "Get the solution of the forward kinematics",
             request=_r(JOINTS), reply=_r(POSE)),
    Register(45, "IS_JOINT_LIMIT", "Check the limit of the joint space",
             request=_r(JOINTS), reply=_r(u8("limited", "1 outside the joint limits, 0 inside")),
             flags=Flag.ANY_FLOAT),
    # ---- 51~100 other functions ---------------------------------------------------------------
    Register(51, "SET_GRAVITY_DIR", "Set the gravity direction",
             request=_r(fp32("direction", 3, "gravity vector in the base frame"))),
    Register(52, "SET_LIMIT_XYZ", "Set the safe boundary range",
             request=_r(i32("boundary", 6, "x+, x-, y+, y-, z+, z- mm (int32 LE)"))),
    Register(55, "GET_JOINT_TAU", "Get current joint torque of the servo",
             reply=_r(fp32("torques", 7, "estimated joint torques N.m"))),
    Register(59, "SET_FENSE_ON", "Safety boundary start switch", request=_r(u8("on"))),
    Register(70, "REPORT_TAU_OR_I", "Set the joint torque (theoretical) and current of servo",
             request=_r(u8("tau_or_i", "0 theoretical torque (Nm), 1 servo current (A)"))),
    Register(73, "SET_WORLD_OFFSET",
             "Set the offset of the user coordinate system and the base coordinate system",
             request=_r(POSE)),
    Register(76, "CAL_POSE_OFFSET", "Calculate the attitude offset of two given points",
             request=_r(fp32("pose1", 6), fp32("pose2", 6),
                        u8("input_aa", "0 RPY, 1 axis-angle"), u8("output_aa", "0 RPY, 1 axis-angle")),
             reply=_r(POSE)),
    Register(77, "SET_SELF_COLLIS_CHECK", "Set the self-collision detection function", request=_r(u8("on"))),
    Register(78, "SET_COLLIS_TOOL", "Set the end tool geometric model for self-collision detection",
             request=one_of(*(_tool_model(n) for n in range(7))),
             doc="0-6 fp32 tool parameters then the tool type: 21 cylinder (radius, height), 22 cuboid "
                 "(x, y, z); 0-5 built-in tools take no parameters."),
    Register(79, "SET_SIMULATION_ROBOT", "Set whether to enable the virtual robotic arm mode",
             request=_r(u8("on"))),
    Register(91, "GET_TCP_POSE_AA", "Get the attitude represented by the axis angle attitude",
             reply=_r(POSE_AA)),
    Register(92, "MOVE_LINE_AA", "Linear motion with axis angle attitude as target",
             request=_r(POSE_AA, fp32("speed"), fp32("acc"), fp32("mvtime"),
                        u8("coord", "0 base frame, 1 tool frame"), u8("relative", "0 absolute, 1 relative")),
             reply=CMDNUM_REPLY, flags=Flag.QUEUED),
    Register(93, "MOVE_SERVO_CART_AA", "Servo cartesian motion (axis angle)",
             request=_r(POSE_AA, fp32("speed"), fp32("acc"),
                        fp32("coord", doc="0 base frame, non-zero tool frame"),
                        u8("relative", "0 absolute, 1 relative")),
             flags=Flag.SERVO,
             doc="The manual types the frame selector as fp32; the SDK sends int32 LE there. Both put 0 "
                 "for the base frame; any other bit pattern means the tool frame."),
    Register(106, "SERVO_DBMSG", "Get the state of the current robotic arm servo",
             reply=_r(Field("servos", "u8", 16, "(state, error code) for joints 1-7, then the gripper")),
             doc="The manual's table starts with a 'commands execution state' byte (0 normal, 1 servo "
                 "error, 3 communication failure) and prints length 0x13, but it has no separate State "
                 "row: that first byte is the reply's state byte. The SDK reads exactly 16 parameter "
                 "bytes as (state, code) pairs, so the table has 16 and the manual's length is off by one."),
    # ---- 2.1.4 peripherals --------------------------------------------------------------------
    Register(124, "RS485_RTU", "Gripper module / end RS-485 Modbus-RTU",
             request=Layout((u8("host", "9: end-effector RS-485"),), rest="rtu", rest_min=1),
             reply=Layout((u8("host"),), rest="rtu"),
             section=_S_IO,
             doc="Raw Modbus-RTU PDU without CRC after the host id, in both directions."),
    Register(127, "TGPIO_W16B", "End-effector register write (IO control, RS-485 baud rate)",
             request=_r(u8("host", "9"), u16("addr"), fp32("value"), u8("sync"), required=3),
             section=_S_IO,
             doc="0x0A15 digital outputs (mask word as a float), 0x1A0B baud-rate index. SDKs for "
                 "firmware >= 2.4.101 append a sync byte."),
    Register(128, "TGPIO_R16B", "Get the end digital / analog input",
             request=_r(u8("host", "9"), u16("addr", "0x0A14 digital, 0x0A16/0x0A17 analog")),
             reply=_r(Field("value", "u32", 1, "u32 BE (the SDK reads it as a signed int)")),
             section=_S_IO),
    Register(131, "CGPIO_GET_DIGIT", "Get configurable digital GPIO input",
             reply=_r(u16("digital", "bit n = input n")), section=_S_IO),
    Register(132, "CGPIO_GET_ANALOG1", "Get analog input AI1",
             reply=_r(u16("analog", "0-4095 for 0-10 V")), section=_S_IO),
    Register(133, "CGPIO_GET_ANALOG2", "Get analog input AI2",
             reply=_r(u16("analog", "0-4095 for 0-10 V")), section=_S_IO),
    Register(134, "CGPIO_SET_DIGIT", "Set configurable digital GPIO output",
             request=one_of(
                 _r(u16("digital", "high byte: enable bits, low byte: values (IO 0-7)"), u8("sync"),
                    required=1),
                 _r(u16("digital"), u16("digital_hi", "the same for IO 8-15"), u8("sync"), required=2),
             ),
             section=_S_IO,
             doc="SDKs send a second word for IO 8-15 and, for firmware >= 2.4.101, a sync byte."),
    Register(135, "CGPIO_SET_ANALOG1", "Set the analog output AO1",
             request=_r(u16("analog", "0-4095 for 0-10 V"), u8("sync"), required=1), section=_S_IO),
    Register(136, "CGPIO_SET_ANALOG2", "Set the analog output AO2",
             request=_r(u16("analog", "0-4095 for 0-10 V"), u8("sync"), required=1), section=_S_IO),
    Register(137, "CGPIO_SET_IN_FUN", "Configure digital input IO function",
             request=_r(u8("ionum"), u8("fun")), flags=Flag.EXTENSION, section="SDK"),
    Register(138, "CGPIO_SET_OUT_FUN", "Configure digital output IO function",
             request=_r(u8("ionum", "0-7"), u8("fun", "0 STOP state, 1 system error, 2 arm moving")),
             section=_S_IO),
    Register(139, "CGPIO_GET_STATE", "Get GPIO state",
             reply=_r(u8("module_state", "0 normal, 3 error, 6 communication failure"), u8("module_error"),
                      u16("di_function"), u16("di_config"), u16("do_function"), u16("do_config"),
                      u16("ai1"), u16("ai2"), u16("ao1"), u16("ao2"),
                      Field("di_fun", "u8", 8, "input functions CI0-7"),
                      Field("do_fun", "u8", 8, "output functions CO0-7"),
                      Field("fun_hi", "u8", 16, "input functions CI8-15, then output functions CO8-15"),
                      required=12),
             section=_S_IO,
             doc="34 bytes in the manual. The SDK uses 50 (with IO 8-15 functions) when the control "
                 "box SN is >= 1300, and indexes IO 8-15 then; send 50 bytes for such a box."),
    Register(142, "DELAYED_CGPIO_SET", "Operation of general digital IO delay output of control box",
             request=_r(u8("ionum", "0-7"), u8("on"), fp32("delay", doc="s")), section=_S_IO),
    Register(143, "DELAYED_TGPIO_SET", "Operation of the end general digital IO delay output",
             request=_r(u8("ionum", "0/1"), u8("on"), fp32("delay", doc="s")), section=_S_IO),
    Register(144, "POSITION_CGPIO_SET",
             "Operation triggered by the position of the general digital IO of the control box",
             request=_r(u8("ionum", "0-7"), u8("on"), fp32("xyz", 3, "trigger point mm"),
                        fp32("tol_r", doc="tolerance radius mm")), section=_S_IO),
    Register(145, "POSITION_TGPIO_SET",
             "Operation triggered by the position of the end general digital IO",
             request=_r(u8("ionum", "0/1"), u8("on"), fp32("xyz", 3, "trigger point mm"),
                        fp32("tol_r", doc="tolerance radius mm")), section=_S_IO),
    Register(146, "SET_IO_STOP_RESET",
             "Whether the control box and end IO are automatically cleared in the STOP state",
             request=_r(u8("io_type", "0 control box IO, 1 end IO"), u8("on")),
             reply=CMDNUM_REPLY, section=_S_IO,
             doc="The manual's reply shows a u16 parameter; the SDK reads none (longer is tolerated)."),
    Register(147, "POSITION_CGPIO_SET_ANALOG",
             "Operation triggered by the position of the general analog IO of the control box",
             request=_r(u8("ionum", "0/1"), u16("value", "0-4095 for 0-10 V"), fp32("xyz", 3),
                        fp32("tol_r")), section=_S_IO),
]

REGISTERS: dict[int, Register] = {r.code: r for r in _TABLE}
BY_NAME: dict[str, Register] = {r.name: r for r in _TABLE}
assert len(REGISTERS) == len(_TABLE) and len(BY_NAME) == len(_TABLE), "duplicate register code or name"


def _has_floats(layout: Layout) -> bool:
    options = getattr(layout, "options", None) or (layout,)
    return any(f.kind == "fp32" for opt in options for f in opt.fields)


#: Registers whose float parameters the controller checks for NaN, infinities and absurd magnitudes:
#: every register with an fp32 request field unless it is flagged ANY_FLOAT.
FLOAT_CHECKED: frozenset[int] = frozenset(
    r.code for r in _TABLE if _has_floats(r.request) and not r.flags & Flag.ANY_FLOAT)


def get(code: int) -> Register | None:
    return REGISTERS.get(code)


def float_checked(table: Mapping[int, Register]) -> frozenset[int]:
    """:data:`FLOAT_CHECKED` for another table (for example ``registers_for(profile)``)."""
    return frozenset(c for c, r in table.items() if _has_floats(r.request) and not r.flags & Flag.ANY_FLOAT)


#: Per-joint vectors carry seven values whatever the arm; those beyond its axes are not read.
JOINT_VECTOR = 7


def per_joint_fields(table: Mapping[int, Register]) -> Mapping[int, tuple[str, ...]]:
    """The request fields of ``table`` that hold one float per joint (J1..J7), by register: a value
    beyond the arm's axes is not read, so it cannot be out of range (the finite-float rule skips it)."""
    out: dict[int, tuple[str, ...]] = {}
    for code, r in table.items():
        options = getattr(r.request, "options", None) or (r.request,)
        names = {f.name for opt in options for f in opt.fields
                 if f.kind == "fp32" and f.count == JOINT_VECTOR}
        if names:
            out[code] = tuple(sorted(names))
    return MappingProxyType(out)


def inf_unchanged(table: Mapping[int, Register]) -> frozenset[int]:
    """Registers of ``table`` whose float fields take +inf as "unchanged"."""
    return frozenset(c for c, r in table.items() if r.flags & Flag.INF_UNCHANGED)


# ---- registers newer than manual V1.6.0 ----------------------------------------------------------
#: ``since`` of registers the SDK sends with no version named for them: they are not in manual
#: V1.6.0, so a 1.6.0 profile does not answer them; every newer profile does.
AFTER_MANUAL = "1.6.1"

_S_SDK = "SDK"
#: The ``since`` of registers that come with a behaviour of protocol/firmware.py's releases.
_FT_SENSOR = first("ft_sensor")
_FEEDBACK = first("feedback")
_PER_SDK = "Not in manual V1.6.0; layout as the SDK sends and reads it."

CHECK_REPLY = Layout((u16("cmdnum", "number of commands in the buffer"),
                      u8("check_result", "only-check moves: non-zero = collision found")), required=1)
"""Reply of the 2.x 'common' moves: the buffer count, then the only-check result (3 bytes)."""

_MOVE_TAIL_DOC = ("only_check_type 0 moves; 1-3 only checks for self-collision (no motion) and the "
                  "reply's third byte is non-zero when a collision is found.")


def _x(code: int, name: str, title: str, *, request: Layout = EMPTY, reply: Layout = EMPTY,
       since: str = AFTER_MANUAL, flags: Flag = Flag.NONE, doc: str = _PER_SDK,
       section: str = _S_SDK) -> Register:
    return Register(code, name, title, request=request, reply=reply, flags=flags | Flag.EXTENSION,
                    section=section, doc=doc, since=since)


_RAW_TAIL = Layout((u8("type"),), rest="data")
_HOST_RAW = Layout((u8("host", "9 end-effector, 11 control box"),), rest="data", rest_min=1)
_SERVO_ADDR = _r(u8("axis", "1-7 joints, 8 F/T sensor"), u16("addr"))
_S32_REPLY = _r(Field("value", "i32be", 1, "s32 BE"))
_CALI_REPLY = _r(fp32("result", 3))
_C_AXIS = Field("c_axis", "u8", 6, "compliant axes x, y, z, Rx, Ry, Rz (0/1)")

#: Registers the SDK can send that manual V1.6.0 lacks, with the first version answering them.
EXTRA_REGISTERS: tuple[Register, ...] = (
    _x(3, "CHECK_VERIFY", "Check the verification", reply=_r(u8("result"))),
    _x(4, "RELOAD_DYNAMICS", "Reload the dynamics parameters", doc="Sent only internally; no parameters."),
    _x(6, "GET_TCP_ROTATION_RADIUS", "Get the TCP rotation radius",
       request=_r(u8("joint")), reply=_r(fp32("radius", doc="mm"))),
    _x(7, "GET_ALLOW_APPROX_MOTION", "Get whether approximate motion is allowed", since="1.9.0",
       reply=_r(u8("on")), doc="The SDK takes the reply's last byte as the switch."),
    _x(46, "IS_TCP_LIMIT", "Check the limit of the cartesian space",
       request=_r(POSE), reply=_r(u8("limited", "non-zero outside the limits"))),
    _x(47, "SET_REDUCED_TRSV", "Set the reduced-mode maximum TCP speed",
       request=_r(fp32("speed", doc="mm/s"))),
    _x(48, "SET_REDUCED_P2PV", "Set the reduced-mode maximum joint speed",
       request=_r(fp32("speed", doc="rad/s"))),
    _x(49, "GET_REDUCED_MODE", "Get whether reduced mode is on", reply=_r(u8("on"))),
    _x(50, "SET_REDUCED_MODE", "Switch reduced mode", request=_r(u8("on"))),
    _x(53, "GET_REDUCED_STATE", "Get the reduced-mode settings",
       reply=_r(u8("on"), Field("boundary", "i16", 6, "x_max, x_min, y_max, y_min, z_max, z_min mm, s16 BE"),
                fp32("tcp_speed", doc="mm/s"), fp32("joint_speed", doc="rad/s"),
                fp32("joint_ranges", 14, "J1min, J1max, ... J7max rad"), u8("fence"), u8("rebound")),
       doc="79 bytes (the SDK reads 21 only below firmware 1.2.11)."),
    _x(56, "SET_SAFE_LEVEL", "Set the safety level", request=_r(u8("level")),
       doc="The SDK's core can send it; no XArmAPI call does."),
    _x(57, "GET_SAFE_LEVEL", "Get the safety level", reply=_r(u8("level"))),
    _x(58, "SET_REDUCED_JRANGE", "Set the reduced-mode joint ranges",
       request=_r(fp32("joint_ranges", 14, "J1min, J1max, ... J7max rad"))),
    _x(60, "SET_COLLIS_REB", "Switch collision rebound", request=_r(u8("on"))),
    _x(61, "SET_TRAJ_RECORD", "Start or stop trajectory recording", request=_r(u8("on"))),
    _x(62, "SAVE_TRAJ", "Save the recorded trajectory",
       request=_r(Field("filename", "str", 81, "ASCII name, at most 80 characters, NUL padded")),
       doc="Finishes with an OTHER_FINISH feedback frame when asked for (code 1 = failed)."),
    _x(63, "LOAD_TRAJ", "Load a trajectory",
       request=_r(Field("filename", "str", 81, "ASCII name, at most 80 characters, NUL padded")),
       doc="Finishes with an OTHER_FINISH feedback frame when asked for (code 1 = failed)."),
    _x(64, "PLAY_TRAJ", "Play back the loaded trajectory",
       request=_r(i32("times", doc="-1 forever"), i32("speed", doc="speed factor 1, 2 or 4"), required=1),
       doc="int32 LE. Mode 11 is reported during playback; OTHER_FINISH feedback at the end."),
    _x(65, "GET_TRAJ_RW_STATUS", "Get the trajectory load/save status",
       reply=_r(u8("status", "0 idle, 1 loading, 2 load ok, 3 load failed, 4 saving, 5 save ok, "
                              "6 save failed"))),
    _x(66, "SET_ALLOW_APPROX_MOTION", "Allow approximate motion", since="1.9.0", request=_r(u8("on"))),
    _x(67, "GET_DH", "Get the D-H parameters", since=first("dh_parameters"),
       reply=_r(fp32("dh", 28, "d, alpha, a, offset per joint"))),
    _x(68, "SET_DH", "Set the D-H parameters", since=first("dh_parameters"),
       request=_r(fp32("dh", 28, "d, alpha, a, offset per joint"), u8("flag", "0-4")),
       reply=_r(u8("result"))),
    _x(69, "GET_MOVEMENT", "Get the movement state", reply=_r(u8("moving")),
       doc="Sent only internally; the SDK reads one byte."),
    _x(71, "SET_TIMER", "Set a timer", request=_r(i32("params", 5)), doc="Sent only internally; int32 LE."),
    _x(72, "CANCEL_TIMER", "Cancel a timer", request=_r(i32("timer_id")), doc="Sent only internally."),
    _x(74, "CNTER_RESET", "Reset the counter", doc="The counter is reported in rich bytes 284..287."),
    _x(75, "CNTER_PLUS", "Increase the counter by one"),
    _x(80, "SET_CARTV_CONTINUE", "Switch continuous cartesian velocity", since="1.9.0", request=_r(u8("on"))),
    _x(81, "VC_SET_JOINTV", "Joint velocity control (mode 4)",
       request=_r(fp32("speeds", 7, "rad/s"), u8("is_sync"), fp32("duration", doc="s"), required=2),
       doc="The SDK appends the duration for firmware >= 1.8.0 when it is >= 0."),
    _x(82, "VC_SET_CARTV", "Cartesian velocity control (mode 5)",
       request=_r(fp32("speeds", 6, "vx, vy, vz mm/s; wx, wy, wz rad/s"), u8("is_tool_coord"),
                  fp32("duration", doc="s"), required=2),
       doc="The SDK appends the duration for firmware >= 1.8.0 when it is >= 0."),
    _x(83, "MOVE_RELATIVE", "Relative motion", since="1.8.100",
       request=_r(fp32("deltas", 7, "dx, dy, dz mm, droll, dpitch, dyaw rad, 0; or dJ1..dJ7 rad"),
                  fp32("speed"), fp32("acc"), fp32("mvtime"), fp32("radius", doc="-1 none"),
                  u8("is_joint_motion", "0 TCP, 1 joint"), u8("is_axis_angle"),
                  u8("only_check_type"), u8("motion_type"), required=7),
       reply=CHECK_REPLY, flags=Flag.QUEUED, doc=_MOVE_TAIL_DOC),
    _x(101, "SERVO_W16B", "Write a 16-bit servo register",
       request=_r(u8("axis"), u16("addr"), fp32("value")), doc="Sent only internally (G-code H101)."),
    _x(102, "SERVO_R16B", "Read a 16-bit servo register", request=_SERVO_ADDR, reply=_S32_REPLY,
       doc="Servo versions (0x0801-0x0803), harmonic type (0x081F), F/T error (axis 8, 0x0010)."),
    _x(103, "SERVO_W32B", "Write a 32-bit servo register",
       request=_r(u8("axis"), u16("addr"), fp32("value")), doc="Sent only internally (G-code H103)."),
    _x(104, "SERVO_R32B", "Read a 32-bit servo register", request=_SERVO_ADDR, reply=_S32_REPLY,
       doc="Sent only internally (G-code H104)."),
    _x(105, "SERVO_ZERO", "Set a servo's zero position", request=_r(u8("axis")),
       doc="Sent only internally (G-code H105)."),
    _x(107, "SERVO_ERROR", "Read a servo error register", request=_SERVO_ADDR, reply=_S32_REPLY,
       doc="The SDK shifts the value right by 16."),
    _x(111, "CALI_TCP_POSE", "Calibrate the TCP position offset", since="1.6.9",
       request=_r(fp32("poses", 24, "4 poses")), reply=_CALI_REPLY),
    _x(112, "CALI_TCP_ORIENT", "Calibrate the TCP orientation offset", since="1.6.9",
       request=_r(fp32("rpy_be", 3), fp32("rpy_bt", 3)), reply=_CALI_REPLY),
    _x(113, "CALI_WRLD_ORIENT", "Calibrate the user orientation offset", since="1.6.9",
       request=_r(fp32("poses", 18, "3 poses"), u8("mode"), u8("trust_ind")), reply=_CALI_REPLY),
    _x(114, "CALI_WRLD_POSE", "Calibrate the user position offset", since="1.6.9",
       request=_r(fp32("rpy_ub", 3), fp32("xyz", 3)), reply=_CALI_REPLY),
    _x(115, "IDEN_FRIC", "Identify the joint friction", since="1.9.0",
       request=_r(Field("robot_sn", "str", 14, "the robot serial number")),
       reply=_r(fp32("result", doc="0.0 success, -1.0 failure")),
       doc="The SDK sends it with protocol id 2 and waits up to 500 s."),
    _x(123, "TGPIO_MB_TIOUT", "Set the end RS-485 Modbus timeout", request=_r(u16("timeout", "ms"))),
    _x(125, "TGPIO_ERR", "Get the gripper error code", reply=_r(u8("error"), u8("code"))),
    _x(129, "TGPIO_W32B", "End-effector 32-bit register write",
       request=_r(u8("host"), u16("addr"), fp32("value"))),
    _x(130, "TGPIO_R32B", "End-effector 32-bit register read",
       request=_r(u8("host"), u16("addr")), reply=_S32_REPLY),
    _x(140, "GET_PWR_VERSION", "Get the power board version", reply=_r(Field("version", "bytes", 6)),
       doc="Sent only internally."),
    _x(141, "GET_HD_TYPES", "Get the hardware types", reply=_r(Field("types", "u8", 2))),
    _x(150, "FTSENSOR_GET_DATA_OLD", "Get the F/T sensor data (old register)",
       reply=_r(fp32("forces", 6, "Fx, Fy, Fz N; Tx, Ty, Tz N.m")),
       doc="get_ft_sensor_data sends this below firmware 1.8.3, register 200 from then on."),
    _x(200, "FTSENSOR_GET_DATA", "Get the F/T sensor data", since=_FT_SENSOR,
       request=_r(u8("raw", "1 raw data (firmware >= 2.6.109)"), required=0),
       reply=_r(fp32("forces", 6, "Fx, Fy, Fz N; Tx, Ty, Tz N.m"))),
    _x(201, "FTSENSOR_ENABLE", "Switch the F/T sensor", since=_FT_SENSOR, request=_r(u8("on"))),
    _x(202, "FTSENSOR_SET_MODE", "Set the F/T application mode", since=_FT_SENSOR,
       request=_r(u8("app", "0 off, 1 impedance/admittance, 2 force control"))),
    _x(203, "FTSENSOR_GET_MODE", "Get the F/T application mode", since=_FT_SENSOR, reply=_r(u8("app"))),
    _x(204, "IDEN_LOAD", "Identify the payload or the F/T sensor load offset",
       since=first("load_identification"),
       request=_r(u8("iden_type", "1 TCP load, 0 F/T load offset"), fp32("mass", doc="estimated kg"),
                  required=1),
       reply=_r(fp32("load", 4, "mass kg, centre x, y, z"), fp32("offsets", 6), required=1),
       doc="TCP load: 4 fp32 back; F/T load offset: 10 fp32. Sent with protocol id 2, long timeouts."),
    _x(205, "FTSENSOR_SET_LOAD_OFFSET", "Set the F/T sensor load and offsets", since=_FT_SENSOR,
       request=_r(fp32("mass", doc="kg"), fp32("center", 3, "m"), fp32("offsets", 6))),
    _x(206, "FTSENSOR_SET_ZERO", "Zero the F/T sensor", since=_FT_SENSOR),
    _x(207, "ADMITTANCE_CONFIG", "Set the admittance parameters", since=_FT_SENSOR,
       request=_r(u8("coord"), _C_AXIS, fp32("M", 6), fp32("K", 6), fp32("B", 6))),
    _x(208, "FORCE_CTRL_PID", "Set the force-control PID", since=_FT_SENSOR,
       request=_r(fp32("kp", 6), fp32("ki", 6), fp32("kd", 6), fp32("xe_limit", 6))),
    _x(209, "FORCE_CTRL_CONFIG", "Set the force-control configuration", since=_FT_SENSOR,
       request=_r(u8("coord"), _C_AXIS, fp32("f_ref", 6), fp32("limits", 6))),
    _x(210, "ADMITTANCE_CTRL_MKB", "Set the admittance M, K, B", since=_FT_SENSOR,
       request=_r(fp32("M", 6), fp32("K", 6), fp32("B", 6))),
    _x(211, "ADMITTANCE_CTRL_CONFIG", "Set the admittance frame and axes", since=_FT_SENSOR,
       request=_r(u8("coord"), _C_AXIS)),
    _x(212, "FTSENSOR_GET_CONFIG", "Get the F/T sensor configuration", since=_FT_SENSOR,
       reply=_r(u8("app_status"), u8("started"), u8("type"), u8("id"), u16("freq"), fp32("mass"),
                fp32("dir_bias"), fp32("centroid", 3), fp32("zero", 6),
                u8("imp_coord"), Field("imp_c_axis", "u8", 6), fp32("M", 6), fp32("K", 6), fp32("B", 6),
                u8("fc_coord"), Field("fc_c_axis", "u8", 6), fp32("f_ref", 6), fp32("limits", 6),
                fp32("kp", 6), fp32("ki", 6), fp32("kd", 6), fp32("xe_limit", 6)),
       doc="280 bytes."),
    _x(230, "GET_TRAJ_SPEEDING", "Check the loaded trajectory's speed",
       request=_r(u8("rate", "1, 2 or 4")),
       reply=_r(Field("result", "i32be"), Field("servo_id", "i32be"), fp32("speed", doc="rad/s"))),
    _x(231, "GET_MAX_JOINT_VELOCITY", "Get the maximum joint velocity",
       request=_r(fp32("speeds", 8, "TCP speed, then 7 joints")), reply=_r(fp32("velocity")),
       doc="Sent only internally."),
    _x(232, "SET_COMMON_PARAM", "Set a generic parameter", since="2.3.0", request=_RAW_TAIL,
       doc="[type] then the value by type (see COMMON_PARAM_LAYOUTS)."),
    _x(233, "GET_COMMON_PARAM", "Get a generic parameter", since="2.3.0",
       request=_r(u8("type")), reply=Layout(rest="data"),
       doc="The value by type: fp32 LE, fp32 lists, or u32 BE integers."),
    _x(234, "GET_COMMON_INFO", "Get generic information", since="2.3.0",
       request=_r(u8("type")), reply=Layout(rest="data"),
       doc="1 PoE status, 2 identification status, 50 record seconds, 101-107 error details."),
    _x(240, "TGPIO_COM_TIOUT", "Set the transparent RS-485 timeout", request=_r(u16("timeout", "ms"))),
    _x(241, "RS485_AGENT", "Transparent RS-485 transfer", request=_HOST_RAW,
       reply=Layout((u8("host"),), rest="data")),
    _x(253, "FEEDBACK_CHECK", "Ask for a feedback frame once every earlier task has finished",
       since=_FEEDBACK, doc="Answered at once; the MOTION_FINISH frame follows when the queue is done."),
    _x(254, "SET_FEEDBACK_TYPE", "Set the feedback-type mask of this connection", since=_FEEDBACK,
       request=_r(u8("mask", "1 motion start, 2 motion finish, 4 trigger, 32 other start, 64 other finish"))),
)

#: Register 232's value layout by parameter type (the reply carries no parameters).
COMMON_PARAM_LAYOUTS: Mapping[int, Layout] = MappingProxyType({
    1: _r(fp32("factor")),
    2: _r(i32("value")), 3: _r(i32("value")),
    6: _r(fp32("thresholds", 6)),
    7: _r(fp32("redundancy", 14)),
    11: _r(i32("on")), 13: _r(i32("on")),
    12: _r(fp32("thresholds", 6)), 14: _r(fp32("distances", 6)),
    15: _r(i32("params", 2)), 16: _r(i32("params", 2)),
    24: _r(i32("timeout", doc="ms")), 25: _r(i32("timeout", doc="ms")),
    26: _r(u8("slave_id"), u8("baud_index"), u8("stop_bits"), u8("parity")),
})

_COMMON_21 = _r(POSE, fp32("speed", doc="mm/s"), fp32("acc", doc="mm/s^2"), fp32("mvtime"),
                fp32("radius", doc="-1 plain line, >= 0 blended"), u8("coord", "0 base, 1 tool"),
                u8("is_axis_angle"), u8("only_check_type"),
                u8("motion_type", "1 linear or joint fallback, 2 joint planning"), required=8)
_COMMON_27 = _r(fp32("pose1", 6), fp32("pose2", 6), fp32("speed"), fp32("acc"), fp32("mvtime"),
                fp32("percent"), u8("coord"), u8("is_axis_angle"), u8("only_check_type"))
_JOINT_MOVE_CHECK = _r(JOINTS, fp32("speed", doc="rad/s"), fp32("acc", doc="rad/s^2"), fp32("mvtime"),
                       u8("only_check_type"), required=4)
_JOINTB_CHECK = _r(JOINTS, fp32("speed"), fp32("acc"), fp32("radius"), u8("only_check_type"), required=4)
_HOME_CHECK = _r(fp32("speed"), fp32("acc"), fp32("mvtime"), u8("only_check_type"), required=3)

#: Later forms of registers, as (the FirmwareProfile property that has them, code, changed Register
#: fields), oldest first: the version is the property's (protocol/firmware.py).
LATER_FORMS: tuple[tuple[str, int, Mapping[str, Any]], ...] = (
    ("common_move_layout", 21, {
        "request": one_of(REGISTERS[21].request, _COMMON_21), "reply": CHECK_REPLY,
        "doc": "36 bytes (manual) or the 'common' 43/44 bytes the SDK sends to a box with the common "
               "forms; " + _MOVE_TAIL_DOC}),
    ("common_move_layout", 27, {
        "request": one_of(REGISTERS[27].request, _COMMON_27), "reply": CHECK_REPLY,
        "doc": "64 bytes (manual) or 67 with [coord, is_axis_angle, only_check_type]."}),
    ("common_move_layout", 23, {"request": _JOINT_MOVE_CHECK, "reply": CHECK_REPLY, "doc": _MOVE_TAIL_DOC}),
    ("common_move_layout", 24, {
        "request": one_of(_r(u8("tau_or_i")), _JOINTB_CHECK), "reply": CHECK_REPLY,
        "doc": "One byte (manual) or a blended joint move with an optional only-check byte."}),
    ("common_move_layout", 25, {"request": _HOME_CHECK, "reply": CHECK_REPLY, "doc": _MOVE_TAIL_DOC}),
    ("inf_unchanged", 21, {"flags": REGISTERS[21].flags | Flag.INF_UNCHANGED}),
    ("inf_unchanged", 23, {"flags": REGISTERS[23].flags | Flag.INF_UNCHANGED}),
    ("inf_unchanged", 83, {"flags": Flag.QUEUED | Flag.EXTENSION | Flag.INF_UNCHANGED}),
)


def all_registers() -> Mapping[int, Register]:
    """Every register of any profile, each in its newest form."""
    return registers_for(NEWEST_PROFILE)


@lru_cache(maxsize=32)
def registers_for(profile: FirmwareProfile) -> Mapping[int, Register]:
    """The register table a box of ``profile``'s firmware answers (read-only).

    Firmware 1.6.0 gives exactly :data:`REGISTERS`; newer versions add the registers of
    :data:`EXTRA_REGISTERS` from their ``since`` version and replace layouts by their later forms
    (:data:`LATER_FORMS`, where the profile has the form's property; the newest applicable wins).
    """
    table: dict[int, Register] = dict(REGISTERS)
    v = profile.version
    for reg in EXTRA_REGISTERS:
        if v.at_least(reg.since):
            table[reg.code] = reg
    for has_form, code, change in LATER_FORMS:
        if getattr(profile, has_form) and code in table:
            table[code] = replace(table[code], **change, since=table[code].since)
    return MappingProxyType(table)
