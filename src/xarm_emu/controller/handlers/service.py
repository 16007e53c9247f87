"""Registers the SDK sends that manual V1.6.0 lacks, apart from motion, feedback and the F/T sensor:
verification, approximate motion, the counter, servo registers, D-H parameters, calibration,
friction identification, hardware types, the generic parameters and information (232-234).

Each answers with the length the SDK reads (the register table's layouts). Where the public
material leaves a value open, the emulator's choice is stated at the constant that holds it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...model import kinematics as kin
from ...model import rotations as rot
from ...protocol import registers as regs
from ..core.controller_protocol import Controller, queue_behind_moves
from ..core.interface import Binding, ParameterError, Values
from ..core.poses import wire_pose_to_matrix
from ..core.state_machine import STATE_MOVING
from ..devices import ft_sensor

#: Register 3: 0 means "verified" (the SDK's check_verification); an emulated box is always verified.
VERIFIED = 0

#: Registers 102/104/107: the servos' firmware version (addresses 0x0801-0x0803) and harmonic drive
#: type (0x081F). The public material gives no values; the emulator's servos report 1.0.0, type 0.
SERVO_VERSION = (1, 0, 0)
HARMONIC_TYPE = 0
ADDR_SERVO_VERSION = 0x0801
ADDR_HARMONIC_TYPE = 0x081F

#: Register 140: the power board version, 6 bytes (the emulator's choice: 1.0.0 in three u16 BE).
POWER_BOARD_VERSION = bytes((0, 1, 0, 0, 0, 0))

#: Register 141: two hardware type bytes; the emulator reports 0, 0 (the public material gives none).
HD_TYPES = (0, 0)

#: Register 233, type 4/5: the tool RS-485 Modbus (register 123) and transparent (register 240)
#: timeouts; 24/25 the control box's. Both SDKs read integer values as u32 BE.
PARAM_TOOL_MODBUS_TIMEOUT = 4
PARAM_TOOL_TRANSPARENT_TIMEOUT = 5

#: The vendor's standard D-H parameters per joint as register 67 carries them: d (mm), alpha (rad),
#: a (mm), offset (rad), for the model's joints (xArm 5, 6 and 7); register 68 may replace them.
_T2 = -1.3849179
_A2 = 289.4866
DH_PARAMS: dict[int, tuple[tuple[float, float, float, float], ...]] = {
    5: ((267.0, -math.pi / 2, 0.0, 0.0), (0.0, 0.0, _A2, _T2), (0.0, 0.0, 351.1588, 2.7331843),
        (0.0, -math.pi / 2, 76.0, -1.3482664), (97.0, 0.0, 0.0, 0.0)),
    6: ((267.0, -math.pi / 2, 0.0, 0.0), (0.0, 0.0, _A2, _T2), (0.0, -math.pi / 2, 77.5, -_T2),
        (342.5, math.pi / 2, 0.0, 0.0), (0.0, -math.pi / 2, 76.0, 0.0), (97.0, 0.0, 0.0, 0.0)),
    7: ((267.0, -math.pi / 2, 0.0, 0.0), (0.0, math.pi / 2, 0.0, 0.0), (293.0, math.pi / 2, 52.5, 0.0),
        (0.0, math.pi / 2, 77.5, 0.0), (342.5, math.pi / 2, 0.0, 0.0), (0.0, -math.pi / 2, 76.0, 0.0),
        (97.0, 0.0, 0.0, 0.0)),
}


@dataclass(slots=True)
class ExtraState:
    """The box's state behind these registers (one per controller, see :func:`extra_state`)."""

    approx_motion: bool = False  # registers 66/7
    cartesian_velocity_continuous: bool = False  # register 80
    dh: list[float] = field(default_factory=list)  # register 67/68: 28 fp32
    #: Register 232's values by parameter type, as the raw value bytes the SDK sent.
    common_params: dict[int, bytes] = field(default_factory=dict)
    #: Servo registers written through 101/103, by (axis, address).
    servo_registers: dict[tuple[int, int], float] = field(default_factory=dict)
    timers: dict[int, tuple[int, ...]] = field(default_factory=dict)  # registers 71/72
    safe_level: int = 0  # registers 56/57


def extra_state(ctl: Controller) -> ExtraState:
    """The :class:`ExtraState` of ``ctl``, created on first use."""
    st = ctl.data.extra_state
    if not isinstance(st, ExtraState):
        st = ExtraState()
        st.dh = [x for joint in DH_PARAMS.get(ctl.dof, ()) for x in joint]
        st.dh += [0.0] * (28 - len(st.dh))
        ctl.data.extra_state = st
    return st


# ---- 3, 4, 6, 7, 66, 69, 80 -----------------------------------------------------------------------
def check_verify(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 3: the verification status (0 verified)."""
    return {"result": VERIFIED}


def reload_dynamics(ctl: Controller, v: Values) -> None:
    """Register 4: the emulator's dynamics model is fixed; nothing to reload."""
    return None


def tcp_rotation_radius(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 6: the distance (mm) of the TCP from the axis of joint ``joint`` (1..dof)."""
    j = int(v["joint"])
    if not 1 <= j <= ctl.dof:
        raise ParameterError(f"joint {j} (1-{ctl.dof})")
    frame = kin.joint_frames(ctl.model, ctl.q)[j - 1]
    axis, origin = frame[:3, 2], frame[:3, 3]
    tcp = kin.tcp_pose(ctl.model, ctl.q, ctl.settings.tcp_offset, (0.0,) * 6)[:3, 3]
    d = tcp - origin
    return {"radius": float(np.linalg.norm(d - np.dot(d, axis) * axis))}


def _switch(v: Values) -> bool:
    on = int(v["on"])
    if on not in (0, 1):
        raise ParameterError(f"switch {on} (0/1)")
    return bool(on)


def get_approx_motion(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 7: whether approximate motion is allowed (register 66)."""
    return {"on": int(extra_state(ctl).approx_motion)}


def set_approx_motion(ctl: Controller, v: Values) -> None:
    """Register 66: allow approximate motion near singularities."""
    extra_state(ctl).approx_motion = _switch(v)


def get_movement(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 69: 1 while the arm moves."""
    return {"moving": int(ctl.state == STATE_MOVING)}


def set_cartesian_velocity_continuous(ctl: Controller, v: Values) -> None:
    """Register 80: Cartesian velocity control (mode 5) keeps its velocity across commands."""
    extra_state(ctl).cartesian_velocity_continuous = _switch(v)


# ---- 46 -------------------------------------------------------------------------------------------
def is_tcp_limit(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 46: 1 when a TCP pose is outside the Cartesian range (manual 4.1), outside the safety
    boundary while it is on (register 52/59), or has no inverse kinematics solution."""
    pose = [float(x) for x in v["pose"]]
    if not all(math.isfinite(x) for x in pose):
        return {"limited": 1}
    rng = ctl.model.tcp_range
    if any(not lo <= pose[i] <= hi for i, (lo, hi) in enumerate(rng[:3])):
        return {"limited": 1}
    s = ctl.settings
    if s.boundary_on:
        b = s.boundary  # x+, x-, y+, y-, z+, z-
        if not all(b[2 * i + 1] <= pose[i] <= b[2 * i] for i in range(3)):
            return {"limited": 1}
    q = kin.ik(ctl.model, ctl.flange_target(wire_pose_to_matrix(tuple(pose))), ctl.q, restarts=True)
    return {"limited": int(q is None)}


# ---- 74/75 the counter ----------------------------------------------------------------------------
def _set_counter(ctl: Controller, value: int) -> None:
    ctl.user_counter = value & 0xFFFFFFFF


def counter_reset(ctl: Controller, v: Values) -> None:
    """Register 74: reset the counter (rich report bytes 285-288) to 0, in its turn in the buffer."""
    queue_behind_moves(ctl, 74, functools.partial(_set_counter, ctl, 0))


def counter_increase(ctl: Controller, v: Values) -> None:
    """Register 75: add one to the counter, in its turn in the buffer."""
    queue_behind_moves(ctl, 75, functools.partial(_increase_counter, ctl))


def _increase_counter(ctl: Controller) -> None:
    _set_counter(ctl, ctl.user_counter + 1)


# ---- 56/57 safety level ---------------------------------------------------------------------------
def set_safe_level(ctl: Controller, v: Values) -> None:
    """Register 56: the safety level (only the SDK's core sends it); read back through 57."""
    extra_state(ctl).safe_level = int(v["level"])


def get_safe_level(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 57: the safety level of register 56."""
    return {"level": extra_state(ctl).safe_level}


# ---- 67/68 D-H parameters -------------------------------------------------------------------------
def get_dh(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 67: 4 fp32 per joint (d, alpha, a, offset), 7 joints."""
    return {"dh": tuple(extra_state(ctl).dh)}


def set_dh(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 68: store D-H parameters (flag 0-4). The emulator's kinematics keep the model's
    nominal geometry; register 67 reads back what was set. Reply 0 = accepted."""
    flag = int(v["flag"])
    if not 0 <= flag <= 4:
        raise ParameterError(f"flag {flag} (0-4)")
    extra_state(ctl).dh = [float(x) for x in v["dh"]]
    return {"result": 0}


# ---- 71/72 timers ---------------------------------------------------------------------------------
def set_timer(ctl: Controller, v: Values) -> None:
    """Register 71 (sent only internally): remember a timer by its first parameter, its id."""
    params = tuple(int(x) for x in v["params"])
    extra_state(ctl).timers[params[0]] = params


def cancel_timer(ctl: Controller, v: Values) -> None:
    """Register 72: forget a timer."""
    extra_state(ctl).timers.pop(int(v["timer_id"]), None)


# ---- 101-107 servo registers ----------------------------------------------------------------------
def _servo_axis(ctl: Controller, axis: int, ft: bool = True) -> None:
    if not (1 <= axis <= ctl.dof or (ft and axis == 8)):
        raise ParameterError(f"servo axis {axis}")


def servo_read(ctl: Controller, v: Values) -> dict[str, Any]:
    """Registers 102/104/107: a servo register as s32 BE. Versions (0x0801-0x0803) and the harmonic
    drive type (0x081F); what 101/103 wrote; 0 otherwise (axis 8, the F/T sensor, is absent)."""
    axis, addr = int(v["axis"]), int(v["addr"])
    _servo_axis(ctl, axis)
    if axis == 8 and addr == ft_sensor.ERROR_ADDRESS and ft_sensor.attached(ctl):
        return {"value": ft_sensor.error_register(ctl)}
    written = extra_state(ctl).servo_registers.get((axis, addr))
    if written is not None:
        return {"value": int(written)}
    if axis <= ctl.dof and ADDR_SERVO_VERSION <= addr < ADDR_SERVO_VERSION + 3:
        return {"value": SERVO_VERSION[addr - ADDR_SERVO_VERSION]}
    if axis <= ctl.dof and addr == ADDR_HARMONIC_TYPE:
        return {"value": HARMONIC_TYPE}
    return {"value": 0}


def servo_error_read(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 107: as 102, the value in the high half (the SDK shifts it right by 16)."""
    value = int(servo_read(ctl, v)["value"])
    return {"value": (value << 16) if abs(value) < 0x8000 else value}


def servo_write(ctl: Controller, v: Values) -> None:
    """Registers 101/103 (sent only internally): store a servo register value (joints 1..dof)."""
    axis = int(v["axis"])
    _servo_axis(ctl, axis, ft=False)
    extra_state(ctl).servo_registers[(axis, int(v["addr"]))] = float(v["value"])


def servo_zero(ctl: Controller, v: Values) -> None:
    """Register 105 (internal): set a servo's zero. The emulated encoders are exact: no effect."""
    _servo_axis(ctl, int(v["axis"]), ft=False)


# ---- 111-115 calibration and identification -------------------------------------------------------
def cali_tcp_pose(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 111: the TCP position offset (mm, flange frame) from four flange poses that touch
    one point, by least squares: R_i p + t_i equal for all i."""
    poses = np.asarray(v["poses"], dtype=float).reshape(4, 6)
    mats = [rot.pose_to_matrix(p) for p in poses]
    rows, rhs = [], []
    for i in range(3):
        a, b = mats[i], mats[i + 1]
        rows.append(a[:3, :3] - b[:3, :3])
        rhs.append(b[:3, 3] - a[:3, 3])
    A, y = np.vstack(rows), np.concatenate(rhs)
    if np.linalg.matrix_rank(A, tol=1e-6) < 3:
        raise ParameterError("the four poses do not determine a point (orientations too alike)")
    p, *_ = np.linalg.lstsq(A, y, rcond=None)
    return {"result": tuple(float(x) for x in p)}


def cali_tcp_orient(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 112: the TCP orientation offset (roll, pitch, yaw) from the flange orientation
    ``rpy_be`` and the wanted tool orientation ``rpy_bt``, both in the base frame."""
    r_be = rot.rpy_to_matrix(*[float(x) for x in v["rpy_be"]])
    r_bt = rot.rpy_to_matrix(*[float(x) for x in v["rpy_bt"]])
    return {"result": tuple(float(x) for x in rot.matrix_to_rpy(r_be.T @ r_bt))}


def cali_user_orient(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 113: the user frame orientation (roll, pitch, yaw) from three TCP points: the
    origin, a point on the x axis and a point in the xy plane (``mode``, ``trust_ind`` accepted)."""
    pts = np.asarray(v["poses"], dtype=float).reshape(3, 6)[:, :3]
    x = pts[1] - pts[0]
    w = pts[2] - pts[0]
    z = np.cross(x, w)
    if np.linalg.norm(x) < 1e-6 or np.linalg.norm(z) < 1e-6:
        raise ParameterError("the three points do not span a plane")
    x, z = x / np.linalg.norm(x), z / np.linalg.norm(z)
    R = np.column_stack((x, np.cross(z, x), z))
    return {"result": tuple(float(a) for a in rot.matrix_to_rpy(R))}


def cali_user_pose(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 114: the user frame origin offset: the TCP point ``xyz`` expressed along the user
    frame's orientation ``rpy_ub`` (what register 73 takes as x, y, z)."""
    R = rot.rpy_to_matrix(*[float(x) for x in v["rpy_ub"]])
    p = np.asarray(v["xyz"], dtype=float)
    return {"result": tuple(float(x) for x in R.T @ p)}


def iden_friction(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 115: joint friction identification; 0.0 when the robot SN sent is this arm's, else
    -1.0 (failure). The emulated joints have no friction to identify."""
    sn = str(v["robot_sn"]).rstrip("\0")
    return {"result": 0.0 if sn and sn[:6] == ctl.robot_sn[:6] else -1.0}


# ---- 140, 141 -------------------------------------------------------------------------------------
def power_version(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 140 (internal): the power board version, 6 bytes."""
    return {"version": POWER_BOARD_VERSION}


def hd_types(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 141: hardware types, 2 bytes."""
    return {"types": HD_TYPES}


# ---- 231 (230 belongs to the trajectory store, handlers/trajectory.py) ---------------------------
def max_joint_velocity(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 231 (internal): the largest joint speed asked, bounded by the model's limit."""
    speeds = [abs(float(x)) for x in v["speeds"][1: 1 + ctl.dof]]
    return {"velocity": min(max(speeds, default=0.0), float(ctl.model.max_joint_speed))}


# ---- 232-234 generic parameters and information ---------------------------------------------------
def _timeout_of(ctl: Controller, param: int) -> int | None:
    gripper = _gripper(ctl)
    if gripper is None:
        return None
    if param == PARAM_TOOL_MODBUS_TIMEOUT:
        return int(gripper.modbus_timeout_ms)
    if param == PARAM_TOOL_TRANSPARENT_TIMEOUT:
        return int(gripper.transparent_timeout_ms)
    return None


def _gripper(ctl: Controller) -> Any:
    for c in getattr(ctl, "components", ()):
        if hasattr(c, "modbus_timeout_ms"):
            return c
    return None


def set_common_param(ctl: Controller, v: Values) -> None:
    """Register 232: ``[type]`` and the value by type
    (:data:`~xarm_emu.protocol.registers.COMMON_PARAM_LAYOUTS`); read back through 233."""
    ptype, data = int(v["type"]), bytes(v["data"])
    layout = regs.COMMON_PARAM_LAYOUTS.get(ptype)
    if layout is None:
        raise ParameterError(f"generic parameter type {ptype}")
    try:
        values = layout.decode(data)
    except Exception as exc:
        raise ParameterError(str(exc)) from exc
    for val in values.values():
        items = val if isinstance(val, tuple | list) else (val,)
        if any(isinstance(x, float) and not (math.isfinite(x) and abs(x) <= 1e9) for x in items):
            raise ParameterError("a float value is not finite or too large")
    if ptype in (24, 25) and int(values["timeout"]) < 0:
        raise ParameterError("negative timeout")
    extra_state(ctl).common_params[ptype] = data[: layout.size]


def _u32be(*values: int) -> bytes:
    return b"".join((int(x) & 0xFFFFFFFF).to_bytes(4, "big") for x in values)


def get_common_param(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 233: a generic parameter. fp32 LE for type 1, 6 fp32 for 6/12/14, 14 fp32 for 7,
    the raw 4 bytes for 26, u32 BE integers otherwise (both SDKs read them big-endian)."""
    ptype = int(v["type"])
    timeout = _timeout_of(ctl, ptype)
    if timeout is not None:
        return {"data": _u32be(timeout)}
    stored = extra_state(ctl).common_params.get(ptype)
    layout = regs.COMMON_PARAM_LAYOUTS.get(ptype)
    if layout is None:
        raise ParameterError(f"generic parameter type {ptype}")
    if stored is None:
        defaults = {1: np.float32(1.0).tobytes()}
        stored = defaults.get(ptype, bytes(layout.size))
    if ptype in (1, 6, 7, 12, 14, 26):
        return {"data": stored}
    ints = [int.from_bytes(stored[i:i + 4], "little", signed=True) for i in range(0, len(stored), 4)]
    return {"data": _u32be(*ints)}


#: Register 234's reply by information type: PoE (1), identification (2), the recorded seconds
#: (50), and the details of errors C31, C37, C23, C24, C60, C38, C54 (101-107) - zeros, as a box
#: with none of those errors answers.
_INFO_SIZES = {1: 1, 2: 1, 50: 4, 101: 9, 102: 5, 103: 29, 104: 5, 105: 8, 106: 29, 107: 9}


def get_common_info(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 234: generic information by type (see :data:`_INFO_SIZES`)."""
    itype = int(v["type"])
    size = _INFO_SIZES.get(itype)
    if size is None:
        raise ParameterError(f"information type {itype}")
    if itype == 50:
        seconds = getattr(ctl, "record_seconds", 0.0)
        return {"data": np.float32(float(seconds)).tobytes()}
    return {"data": bytes(size)}


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(3, check_verify),
    Binding(4, reload_dynamics),
    Binding(6, tcp_rotation_radius),
    Binding(7, get_approx_motion),
    Binding(46, is_tcp_limit),
    Binding(56, set_safe_level),
    Binding(57, get_safe_level),
    Binding(66, set_approx_motion),
    Binding(67, get_dh),
    Binding(68, set_dh),
    Binding(69, get_movement),
    Binding(71, set_timer),
    Binding(72, cancel_timer),
    Binding(74, counter_reset),
    Binding(75, counter_increase),
    Binding(80, set_cartesian_velocity_continuous),
    Binding(101, servo_write),
    Binding(102, servo_read),
    Binding(103, servo_write),
    Binding(104, servo_read),
    Binding(105, servo_zero),
    Binding(107, servo_error_read),
    Binding(111, cali_tcp_pose),
    Binding(112, cali_tcp_orient),
    Binding(113, cali_user_orient),
    Binding(114, cali_user_pose),
    Binding(115, iden_friction),
    Binding(140, power_version),
    Binding(141, hd_types),
    Binding(231, max_joint_velocity),
    Binding(232, set_common_param),
    Binding(233, get_common_param),
    Binding(234, get_common_info),
)
