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
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

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
