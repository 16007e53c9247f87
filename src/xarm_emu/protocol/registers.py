"""The register table: every command of the manual's section 2.1.3 and 2.1.4.

One entry per register: code, name, request and reply layouts, flags. This is
the single home of byte layouts: the controller's dispatcher, the client, the
docs and the tests all read it.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from .layouts import EMPTY, Field, Layout, fp32, u8, u16


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


@dataclass(frozen=True)
class Register:
    code: int
    name: str
    title: str
    request: Layout = EMPTY
    reply: Layout = EMPTY
    flags: Flag = Flag.NONE
    section: str = "2.1.3"
    doc: str = field(default="", compare=False)

    @property
    def system_reset(self) -> bool:
        return bool(self.flags & Flag.SYSTEM_RESET)

    @property
    def queued(self) -> bool:
        return bool(self.flags & Flag.QUEUED)


#: Reply of queued commands: the number of commands in the buffer (u16 BE).
CMDNUM_REPLY = Layout((u16("cmdnum"),))

POSE = fp32("pose", 6, "x, y, z mm; roll, pitch, yaw rad")
JOINTS = fp32("joints", 7, "J1..J7 rad")


def _r(*fields: Field, required: int | None = None) -> Layout:
    return Layout(tuple(fields), required=required)


_TABLE: list[Register] = [
    Register(1, "GET_VERSION", "Get version information", reply=_r(Field("version", "str", 40)),
             section="2.1.3.2"),
    Register(11, "MOTION_EN", "Enable/Disable servo", request=_r(u8("joint"), u8("enable")),
             flags=Flag.SYSTEM_RESET),
    Register(12, "SET_STATE", "Motion state setting", request=_r(u8("state"))),
    Register(13, "GET_STATE", "Get the motion state", reply=_r(u8("state"))),
    Register(14, "GET_CMDNUM", "Get the number of commands in the command buffer", reply=CMDNUM_REPLY),
    Register(15, "GET_ERROR", "Get error and warning code", reply=_r(u8("error"), u8("warning"))),
    Register(41, "GET_TCP_POSE", "Get the current cartesian position", reply=_r(POSE)),
    Register(42, "GET_JOINT_POS", "Get the current joint position", request=_r(u8("num"), required=0),
             reply=_r(JOINTS)),
    Register(23, "MOVE_JOINT", "P2P joint motion",
             request=_r(JOINTS, fp32("speed"), fp32("acc"), fp32("mvtime")),
             reply=CMDNUM_REPLY, flags=Flag.QUEUED),
]

REGISTERS: dict[int, Register] = {r.code: r for r in _TABLE}
BY_NAME: dict[str, Register] = {r.name: r for r in _TABLE}


def get(code: int) -> Register | None:
    return REGISTERS.get(code)
