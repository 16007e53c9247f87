"""Automatic report frames of ports 30003, 30001 and 30002 (manual section 2.1.6).

Three reports, each a prefix of the next:

- ``REPORT_TCP_DEVELOP`` (port 30003, 100 Hz): 87 bytes, motion state and joints/pose/torques.
- ``REPORT_TCP_NORMAL`` (port 30001, 5 Hz): 145 bytes, adds brakes, error, TCP offset, load,
  sensitivities and gravity direction.
- ``REPORT_TCP_RICH`` (port 30002, 5 Hz): 433 bytes, adds robot identity, limits, servo codes,
  temperatures, speeds, offsets, collision model, voltages, currents and the control box GPIO.

Every frame starts with its total length as u32 big-endian. Following section 2.1.2
("automatic reporting data analysis"), fp32 are little-endian and multi-byte integers big-endian.
The manual numbers bytes from 1; the offsets below are 0-based (manual byte N is offset N-1).

Where the manual is unclear, the official SDK's reading decides:
byte 89 is the enable bits (the manual repeats "brake"), bytes 150..151 are reserved
(motor tid/fid), temperatures are signed bytes, joint voltages are V x 100, analog values are
12-bit counts of 0..10 V.

Encoding uses precompiled :class:`struct.Struct` objects written into one buffer; it runs for
every client at 100 Hz.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from .firmware import DEFAULT_VERSION, FirmwareProfile

DEVELOP_SIZE = 87
NORMAL_SIZE = 145
RICH_SIZE = 433

DEVELOP_PORT = 30003
NORMAL_PORT = 30001
RICH_PORT = 30002

DEVELOP_RATE = 100.0  # Hz, section 2.1.6
NORMAL_RATE = 5.0
RICH_RATE = 5.0

MASTER_ID = 0xAA  # rich byte 148, "0xAA fixed"
SLAVE_ID = 0x55  # rich byte 149, "0x55 fixed"
VERSION_SIZE = 30  # rich bytes 152..181

ANALOG_FULL_SCALE = 10.0  # V for 4095 counts (SDK reading of rich bytes 394..401)
ANALOG_COUNTS = 4095
VOLTAGE_SCALE = 100.0  # joint voltages are sent as V x 100 (rich bytes 342..355)

_Z7 = (0.0,) * 7
_Z6 = (0.0,) * 6


@dataclass(slots=True)
class ReportSnapshot:
    """Everything the three reports carry, in project units (mm, rad, kg, s, V, A, degC).

    Per-joint vectors have 7 entries on the wire; shorter ones are padded with zeros.
    The defaults describe a powered xArm6 that is not enabled, so ``ReportSnapshot()`` encodes
    into frames the SDK accepts.
    """

    # --- REPORT_TCP_DEVELOP, bytes 1..87 ---
    state: int = 4  # motion state (register 13), low nibble of byte 5
    mode: int = 0  # motion mode (register 19), high nibble of byte 5
    cmdnum: int = 0  # commands in the cache, bytes 6..7
    joints: Sequence[float] = _Z7  # rad, bytes 8..35
    pose: Sequence[float] = _Z6  # x, y, z mm, roll, pitch, yaw rad, bytes 36..59
    torques: Sequence[float] = _Z7  # joint torques N*m, bytes 60..87

    # --- REPORT_TCP_NORMAL, bytes 88..145 ---
    brake_bits: int = 0  # bit i: brake of joint i+1 released
    enable_bits: int = 0  # bit i: joint i+1 enabled
    error: int = 0  # control box error code (section 3.2.1)
    warning: int = 0  # warning code (section 3.2.2)
    tcp_offset: Sequence[float] = _Z6  # mm, rad
    tcp_load: Sequence[float] = (0.0, 0.0, 0.0, 0.0)  # mass kg, centre of mass x, y, z mm
    collision_sensitivity: int = 3  # 0..5
    teach_sensitivity: int = 1  # 1..5
    gravity_direction: Sequence[float] = (0.0, 0.0, -1.0)  # unit vector in the base frame

    # --- REPORT_TCP_RICH, bytes 146..433 ---
    robot_type: int = 6
    axis: int = 6
    master_id: int = MASTER_ID
    slave_id: int = SLAVE_ID
    motor_tid: int = 0  # byte 150, reserved in the manual
    motor_fid: int = 0  # byte 151, reserved in the manual
    version: str = f"6,6,XI1304,AC1303,v{DEFAULT_VERSION}"  # 30 bytes, NUL padded, truncated if longer
    # Limits default to the ranges of manual table 1.2 (1000 mm/s, 50000 mm/s^2, 10000 mm/s^3,
    # 180 deg/s, 1145 deg/s^2, 28647 deg/s^3).
    tcp_jerk: float = 10000.0  # mm/s^3
    tcp_min_acc: float = 1.0  # mm/s^2
    tcp_max_acc: float = 50000.0
    tcp_min_speed: float = 0.1  # mm/s
    tcp_max_speed: float = 1000.0
    joint_jerk: float = 500.0  # rad/s^3
    joint_min_acc: float = 0.01  # rad/s^2
    joint_max_acc: float = 20.0
    joint_min_speed: float = 0.0001  # rad/s
    joint_max_speed: float = math.pi
    rot_jerk: float = 2.3  # rad/s^3, not user settable
    max_rot_acc: float = 2.7  # rad/s^2, not user settable
    servo_codes: Sequence[tuple[int, int]] = ((0, 0),) * 7  # (error type, error code) per joint
    tgpio_code: tuple[int, int] = (0, 0)  # end IO (error type, error code)
    temperatures: Sequence[int] = (0,) * 7  # degC, signed byte per joint
    tcp_speed: float = 0.0  # planned TCP speed, mm/s
    joint_speeds: Sequence[float] = _Z7  # planned joint speeds, rad/s
    counter: int = 0  # the current commands counter (u32 BE, bytes 285..288)
    world_offset: Sequence[float] = _Z6  # user coordinate offset, mm, rad
    cgpio_reset_on_stop: bool = False  # byte 313
    tgpio_reset_on_stop: bool = False  # byte 314
    simulation: bool = False  # byte 315, virtual robot
    self_collision: bool = False  # byte 316, self-collision detection on
    collision_tool_type: int = 0  # byte 317
    collision_tool_params: Sequence[float] = _Z6  # mm, bytes 318..341
    joint_voltages: Sequence[float] = _Z7  # V
    joint_currents: Sequence[float] = _Z7  # A
    cgpio_state: int = 0  # GPIO module status: 0 normal, 3 gripper error, 6 communication failed
    cgpio_error: int = 0  # GPIO module error code
    cgpio_input_function: int = 0x0000  # u16 digital input function IO status
    cgpio_input_config: int = 0xFFFF  # u16 digital input configuration IO status (inputs idle high)
    cgpio_output_function: int = 0x0000  # u16 digital output function IO status
    cgpio_output_config: int = 0x0000  # u16 digital output configuration IO status
    analog_inputs: Sequence[float] = (0.0, 0.0)  # V
    analog_outputs: Sequence[float] = (0.0, 0.0)  # V
    input_functions: Sequence[int] = (0,) * 16  # function number of digital inputs IO0..IO15
    output_functions: Sequence[int] = (0,) * 16  # function number of digital outputs IO0..IO15

    # --- firmware 2.x tails: develop bytes 87..134, rich bytes 433..586 (0-based) ---
    ft_ext_force: Sequence[float] = _Z6  # F/T filtered and compensated Fx..Tz (N, N*m)
    ft_raw_force: Sequence[float] = _Z6  # F/T raw Fx..Tz
    iden_progress: int = 0  # identification progress, %
    pose_aa: Sequence[float] = (0.0, 0.0, 0.0)  # Rx, Ry, Rz rad (axis-angle orientation)
    report_current: bool = False  # config bit 2 (register 70)
    approx_motion: bool = False  # config bit 3 (register 66)
    cart_continuous: bool = False  # config bit 4 (register 80)
    reduced_mode: bool = False  # register 50
    reduced_tcp_boundary: Sequence[int] = (0,) * 6  # x+, x-, y+, y-, z+, z- mm (register 52)
    reduced_max_tcp_speed: float = 0.0  # mm/s (register 47)
    reduced_max_joint_speed: float = 0.0  # rad/s (register 48)
    reduced_joint_ranges: Sequence[float] = (0.0,) * 14  # J1min, J1max, ... J7max rad (register 58)
    fence: bool = False  # safety boundary on (register 59)
    collision_rebound: bool = False  # register 60
    cgpio_alarm: int = 0  # u32, semantics not public
    ft_enabled: bool = False  # register 201
    monitor_device_type: int = 0  # external device monitored through register 232 type 15
    monitor_device_state: int = 0
    monitor_device_values: Sequence[int] = (0, 0, 0)  # position, speed, current (s16)
    # --- real-time report (port 30000) only ---
    timestamp_us: int = 0
    joint_accelerations: Sequence[float] = _Z7  # rad/s^2
    tcp_velocity: Sequence[float] = _Z6  # mm/s, rad/s

    @property
    def state_byte(self) -> int:
        """Byte 5 of every report: state in bits 0..3, mode in bits 4..7."""
        return _state_byte(self.state, self.mode)


# --- wire layout (0-based offsets) ---------------------------------------------------------------

_LENGTH = struct.Struct(">I")
_HEAD = struct.Struct(">IBH")  # 0: length, state/mode, cmdnum
_MOTION = struct.Struct("<7f6f7f")  # 7: joints, pose, torques
_NORMAL = struct.Struct("<4B6f4f2B3f")  # 87: brake, enable, error, warning, offset, load, sens, gravity
_RICH_A = struct.Struct(f"<6B{VERSION_SIZE}s5f5f2f16B7b8f")  # 145: identity .. speeds
_RICH_COUNTER = struct.Struct(">I")  # 284
_RICH_B = struct.Struct("<6f5B6f")  # 288: world offset, switches, collision tool
_RICH_VOLTS = struct.Struct(">7H")  # 341
_RICH_C = struct.Struct("<7f2B")  # 355: currents, GPIO module state, error
_RICH_IO = struct.Struct(">8H")  # 385: IO words, analog in/out
_RICH_FUNCS = struct.Struct("32B")  # 401: input functions 0..7, output 0..7, input 8..15, output 8..15

OFF_MOTION = 7
OFF_NORMAL = 87
OFF_RICH_A = 145
OFF_COUNTER = 284
OFF_RICH_B = 288
OFF_VOLTS = 341
OFF_RICH_C = 355
OFF_IO = 385
OFF_FUNCS = 401

assert _HEAD.size == OFF_MOTION and OFF_MOTION + _MOTION.size == DEVELOP_SIZE
assert OFF_NORMAL + _NORMAL.size == NORMAL_SIZE
assert OFF_RICH_A + _RICH_A.size == OFF_COUNTER and OFF_COUNTER + 4 == OFF_RICH_B
assert OFF_RICH_B + _RICH_B.size == OFF_VOLTS and OFF_VOLTS + _RICH_VOLTS.size == OFF_RICH_C
assert OFF_RICH_C + _RICH_C.size == OFF_IO and OFF_IO + _RICH_IO.size == OFF_FUNCS
assert OFF_FUNCS + _RICH_FUNCS.size == RICH_SIZE


class ReportError(ValueError):
    """Bytes that are not a report frame of the expected kind."""


def _state_byte(state: int, mode: int) -> int:
    if not (0 <= state <= 15 and 0 <= mode <= 15):
        raise ValueError(f"state {state} / mode {mode} do not fit a nibble")
    return (mode << 4) | state


def _n(seq: Sequence, n: int, fill: object = 0.0) -> Sequence:
    """``seq`` padded with ``fill`` (or cut) to exactly ``n`` items."""
    if len(seq) == n:
        return seq
    items = list(seq)[:n]
    return items + [fill] * (n - len(items))


def _u16(x: float) -> int:
    """Round and clamp to 0..65535."""
    return min(max(int(x + 0.5), 0), 0xFFFF) if math.isfinite(x) else 0


def volts_to_counts(v: float) -> int:
    """Analog value in volts to the 12-bit count the report carries (4095 = 10 V)."""
    return _u16(v * (ANALOG_COUNTS / ANALOG_FULL_SCALE))


def counts_to_volts(c: int) -> float:
    return c * (ANALOG_FULL_SCALE / ANALOG_COUNTS)


def _pack_develop(buf: bytearray, s: ReportSnapshot, size: int) -> None:
    _HEAD.pack_into(buf, 0, size, _state_byte(s.state, s.mode), s.cmdnum)
    _MOTION.pack_into(buf, OFF_MOTION, *_n(s.joints, 7), *s.pose, *_n(s.torques, 7))


def _pack_normal(buf: bytearray, s: ReportSnapshot) -> None:
    _NORMAL.pack_into(buf, OFF_NORMAL, s.brake_bits, s.enable_bits, s.error, s.warning,
                      *s.tcp_offset, *s.tcp_load, s.collision_sensitivity, s.teach_sensitivity,
                      *s.gravity_direction)


def _pack_rich(buf: bytearray, s: ReportSnapshot) -> None:
    codes = [c for pair in _n(s.servo_codes, 7, (0, 0)) for c in pair]
    _RICH_A.pack_into(
        buf, OFF_RICH_A,
        s.robot_type, s.axis, s.master_id, s.slave_id, s.motor_tid, s.motor_fid,
        s.version.encode("ascii", "replace"),
        s.tcp_jerk, s.tcp_min_acc, s.tcp_max_acc, s.tcp_min_speed, s.tcp_max_speed,
        s.joint_jerk, s.joint_min_acc, s.joint_max_acc, s.joint_min_speed, s.joint_max_speed,
        s.rot_jerk, s.max_rot_acc,
        *codes, *s.tgpio_code,
        *_n(s.temperatures, 7, 0),
        s.tcp_speed, *_n(s.joint_speeds, 7),
    )
    _RICH_COUNTER.pack_into(buf, OFF_COUNTER, s.counter & 0xFFFFFFFF)
    _RICH_B.pack_into(buf, OFF_RICH_B, *s.world_offset,
                      s.cgpio_reset_on_stop, s.tgpio_reset_on_stop, s.simulation, s.self_collision,
                      s.collision_tool_type, *s.collision_tool_params)
    try:  # fast path; out-of-range values are clamped below
        volts = [int(v * VOLTAGE_SCALE + 0.5) for v in _n(s.joint_voltages, 7)]
        _RICH_VOLTS.pack_into(buf, OFF_VOLTS, *volts)
    except (struct.error, ValueError, OverflowError):  # out of range, NaN, inf
        _RICH_VOLTS.pack_into(buf, OFF_VOLTS, *[_u16(v * VOLTAGE_SCALE) for v in _n(s.joint_voltages, 7)])
    _RICH_C.pack_into(buf, OFF_RICH_C, *_n(s.joint_currents, 7), s.cgpio_state, s.cgpio_error)
    k = ANALOG_COUNTS / ANALOG_FULL_SCALE
    analog = [*s.analog_inputs, *s.analog_outputs]
    words = (s.cgpio_input_function, s.cgpio_input_config, s.cgpio_output_function, s.cgpio_output_config)
    try:
        _RICH_IO.pack_into(buf, OFF_IO, *words, *[int(v * k + 0.5) for v in analog])
    except (struct.error, ValueError, OverflowError):
        _RICH_IO.pack_into(buf, OFF_IO, *words, *[_u16(v * k) for v in analog])
    fi, fo = _n(s.input_functions, 16, 0), _n(s.output_functions, 16, 0)
    _RICH_FUNCS.pack_into(buf, OFF_FUNCS, *fi[:8], *fo[:8], *fi[8:], *fo[8:])


def encode_develop(s: ReportSnapshot) -> bytes:
    """REPORT_TCP_DEVELOP frame, 87 bytes (section 2.1.6, port 30003)."""
    buf = bytearray(DEVELOP_SIZE)
    _pack_develop(buf, s, DEVELOP_SIZE)
    return bytes(buf)


def encode_normal(s: ReportSnapshot) -> bytes:
    """REPORT_TCP_NORMAL frame, 145 bytes (section 2.1.6, port 30001)."""
    buf = bytearray(NORMAL_SIZE)
    _pack_develop(buf, s, NORMAL_SIZE)
    _pack_normal(buf, s)
    return bytes(buf)


def _rich_frame(s: ReportSnapshot, size: int) -> bytearray:
    """A rich frame of ``size`` bytes with the manual's 433 packed (section 2.1.6)."""
    buf = bytearray(size)
    _pack_develop(buf, s, size)
    _pack_normal(buf, s)
    _pack_rich(buf, s)
    return buf


def encode_rich(s: ReportSnapshot) -> bytes:
    """REPORT_TCP_RICH frame, 433 bytes (section 2.1.6, port 30002)."""
    return bytes(_rich_frame(s, RICH_SIZE))


# --- decoding ------------------------------------------------------------------------------------


def _check(data: bytes, size: int, name: str) -> None:
    if len(data) < size:
        raise ReportError(f"{name} report needs {size} bytes, got {len(data)}")
    (length,) = _LENGTH.unpack_from(data, 0)
    if length != len(data):
        raise ReportError(f"{name} report length field {length} != {len(data)} bytes received")


def _unpack_develop(data: bytes, s: ReportSnapshot) -> None:
    _, sm, s.cmdnum = _HEAD.unpack_from(data, 0)
    s.state, s.mode = sm & 0x0F, sm >> 4
    v = _MOTION.unpack_from(data, OFF_MOTION)
    s.joints, s.pose, s.torques = v[0:7], v[7:13], v[13:20]


def _unpack_normal(data: bytes, s: ReportSnapshot) -> None:
    v = _NORMAL.unpack_from(data, OFF_NORMAL)
    s.brake_bits, s.enable_bits, s.error, s.warning = v[0:4]
    s.tcp_offset, s.tcp_load = v[4:10], v[10:14]
    s.collision_sensitivity, s.teach_sensitivity = v[14:16]
    s.gravity_direction = v[16:19]


def _unpack_rich(data: bytes, s: ReportSnapshot) -> None:
    v = _RICH_A.unpack_from(data, OFF_RICH_A)
    s.robot_type, s.axis, s.master_id, s.slave_id, s.motor_tid, s.motor_fid = v[0:6]
    s.version = v[6].split(b"\0", 1)[0].decode("ascii", "replace")
    (s.tcp_jerk, s.tcp_min_acc, s.tcp_max_acc, s.tcp_min_speed, s.tcp_max_speed,
     s.joint_jerk, s.joint_min_acc, s.joint_max_acc, s.joint_min_speed, s.joint_max_speed,
     s.rot_jerk, s.max_rot_acc) = v[7:19]
    codes = v[19:35]
    s.servo_codes = tuple((codes[2 * i], codes[2 * i + 1]) for i in range(7))
    s.tgpio_code = (codes[14], codes[15])
    s.temperatures = v[35:42]
    s.tcp_speed, s.joint_speeds = v[42], v[43:50]
    (s.counter,) = _RICH_COUNTER.unpack_from(data, OFF_COUNTER)
    v = _RICH_B.unpack_from(data, OFF_RICH_B)
    s.world_offset = v[0:6]
    s.cgpio_reset_on_stop, s.tgpio_reset_on_stop, s.simulation, s.self_collision = map(bool, v[6:10])
    s.collision_tool_type, s.collision_tool_params = v[10], v[11:17]
    s.joint_voltages = tuple(x / VOLTAGE_SCALE for x in _RICH_VOLTS.unpack_from(data, OFF_VOLTS))
    v = _RICH_C.unpack_from(data, OFF_RICH_C)
    s.joint_currents, s.cgpio_state, s.cgpio_error = v[0:7], v[7], v[8]
    v = _RICH_IO.unpack_from(data, OFF_IO)
    s.cgpio_input_function, s.cgpio_input_config, s.cgpio_output_function, s.cgpio_output_config = v[0:4]
    s.analog_inputs = (counts_to_volts(v[4]), counts_to_volts(v[5]))
    s.analog_outputs = (counts_to_volts(v[6]), counts_to_volts(v[7]))
    f = _RICH_FUNCS.unpack_from(data, OFF_FUNCS)
    s.input_functions = f[0:8] + f[16:24]
    s.output_functions = f[8:16] + f[24:32]


def _decode(data: bytes, size: int, kind: str,
            parts: tuple[Callable[[bytes, ReportSnapshot], None], ...]) -> ReportSnapshot:
    _check(data, size, kind)
    s = ReportSnapshot()
    for unpack in parts:
        unpack(data, s)
    return s


def decode_develop(data: bytes) -> ReportSnapshot:
    """Read a REPORT_TCP_DEVELOP frame (or the develop prefix of a longer frame whose
    length field matches its size). Fields the frame lacks keep their defaults."""
    return _decode(data, DEVELOP_SIZE, "develop", (_unpack_develop,))


def decode_normal(data: bytes) -> ReportSnapshot:
    """Read a REPORT_TCP_NORMAL frame (section 2.1.6)."""
    return _decode(data, NORMAL_SIZE, "normal", (_unpack_develop, _unpack_normal))


def decode_rich(data: bytes) -> ReportSnapshot:
    """Read a REPORT_TCP_RICH frame of at least 433 bytes (section 2.1.6); bytes beyond are ignored."""
    return _decode(data, RICH_SIZE, "rich", (_unpack_develop, _unpack_normal, _unpack_rich))


#: Report port -> encoder, for the server.
ENCODERS: dict[int, Callable[[ReportSnapshot], bytes]] = {
    DEVELOP_PORT: encode_develop,
    NORMAL_PORT: encode_normal,
    RICH_PORT: encode_rich,
}

#: Report port -> default frequency in Hz (section 2.1.6).
RATES: dict[int, float] = {DEVELOP_PORT: DEVELOP_RATE, NORMAL_PORT: NORMAL_RATE, RICH_PORT: RICH_RATE}

DECODERS: dict[int, Callable[[bytes], ReportSnapshot]] = {
    DEVELOP_PORT: decode_develop,
    NORMAL_PORT: decode_normal,
    RICH_PORT: decode_rich,
}


# --- firmware 2.x reports -----------------------------------------------------------------------

RICH2_SIZE = 587  # rich report with the 2.x tail (F/T, identification, axis-angle, reduced mode, monitor)
DEVELOP2_SIZE = 135  # develop report with F/T external and raw forces
REALTIME_SIZE = 804  # port 30000
REALTIME_PORT = 30000
REALTIME_RATE = 250.0  # Hz (200 with an F/T sensor)
#: Ports whose frames carry the controller's clock (the real-time report's timestamp): each of their
#: frames differs from the last. The other reports show the clock nowhere; their frames change only
#: when the box does.
CLOCKED_PORTS = frozenset({REALTIME_PORT})

OFF_DEVELOP_FT = 87
OFF_RICH_TAIL = 433
OFF_CONFIG_BITS = 494
OFF_REDUCED = 495
OFF_ALARM = 574

_FT2 = struct.Struct("<6f6f")  # 87 (develop) / 433 (rich): F/T external, raw
_RICH_T1 = struct.Struct("<B3fB")  # 481: identification progress, axis-angle, config bits
_RICH_REDUCED = struct.Struct(">B6h")  # 495: reduced mode on, TCP boundary s16 BE
_RICH_REDUCED_F = struct.Struct("<2f14f2B")  # 508: max TCP/joint speed, joint ranges, fence, rebound
_RICH_T2 = struct.Struct(">IBBB3h")  # 574: CGPIO alarm, F/T bits, monitored device type/state/values

assert OFF_DEVELOP_FT + _FT2.size == DEVELOP2_SIZE
assert OFF_RICH_TAIL + _FT2.size + _RICH_T1.size == OFF_REDUCED
assert OFF_REDUCED + _RICH_REDUCED.size + _RICH_REDUCED_F.size == OFF_ALARM
assert OFF_ALARM + _RICH_T2.size == RICH2_SIZE

_RT_HEAD = struct.Struct(">IQBH")  # 0: length, timestamp us, state/mode, cmdnum
_RT_JOINTS = struct.Struct("<56f")  # 32: 8 blocks of 7 joint values
_RT_TCP = struct.Struct("<42f")  # 424: 7 blocks of 6 TCP values
_RT_FT = struct.Struct("<12f")  # 688: F/T raw, filtered
_RT_MON = struct.Struct(">BB3h")  # 736: monitored device
_RT_IO = struct.Struct(">HH4hHH2h")  # 784: CGPIO DI, DO words, 2 AI, 2 AO (mV), tool DI, DO, 2 tool AI (mV)
OFF_RT_JOINTS, OFF_RT_TCP, OFF_RT_FT, OFF_RT_MON, OFF_RT_IO = 32, 424, 688, 736, 784
assert OFF_RT_IO + _RT_IO.size == REALTIME_SIZE
#: The joint section's blocks of seven float32 values (from OFF_RT_JOINTS) that
#: :func:`decode_realtime` reads: the actual joints, speeds, accelerations, currents and torques
#: (blocks 0-2 hold the targets), and where the actual TCP position starts in the TCP section.
RT_BLOCKS = {"joints": 3, "joint_speeds": 4, "joint_accelerations": 5, "joint_currents": 6, "torques": 7}
RT_TCP_POSITION = 12
_RT_SLICES = {name: slice(7 * b, 7 * b + 7) for name, b in RT_BLOCKS.items()}
#: The same fields by byte offset, for readers of many frames at once (the replay of a recording):
#: name -> (offset, struct format of one value, count). The head is _RT_HEAD's: length, timestamp,
#: then the byte with the state in its low and the mode in its high four bits.
REALTIME_COLUMNS: dict[str, tuple[int, str, int]] = {
    "timestamp_us": (struct.calcsize(">I"), ">Q", 1),
    "state_mode": (struct.calcsize(">IQ"), "B", 1),
    **{name: (OFF_RT_JOINTS + 4 * 7 * RT_BLOCKS[name], "<f", 7)
       for name in ("joints", "joint_speeds", "joint_currents", "torques")},
    "position": (OFF_RT_TCP + 4 * RT_TCP_POSITION, "<f", 3),
}


def _config_bits(s: ReportSnapshot) -> int:
    return (s.reduced_mode | s.fence << 1 | s.report_current << 2 | s.approx_motion << 3
            | s.cart_continuous << 4)


def _s16(x: float) -> int:
    return min(max(int(round(x)), -0x8000), 0x7FFF) if math.isfinite(x) else 0


def _pack_rich_tail(buf: bytearray, s: ReportSnapshot) -> None:
    _FT2.pack_into(buf, OFF_RICH_TAIL, *_n(s.ft_ext_force, 6), *_n(s.ft_raw_force, 6))
    _RICH_T1.pack_into(buf, 481, s.iden_progress & 0xFF, *_n(s.pose_aa, 3), _config_bits(s))
    bound = [_s16(v) for v in _n(s.reduced_tcp_boundary, 6, 0)]
    _RICH_REDUCED.pack_into(buf, OFF_REDUCED, s.reduced_mode, *bound)
    _RICH_REDUCED_F.pack_into(buf, 508, s.reduced_max_tcp_speed, s.reduced_max_joint_speed,
                              *_n(s.reduced_joint_ranges, 14), s.fence, s.collision_rebound)
    _RICH_T2.pack_into(buf, OFF_ALARM, s.cgpio_alarm & 0xFFFFFFFF, int(s.ft_enabled),
                       s.monitor_device_type & 0xFF, s.monitor_device_state & 0xFF,
                       *[_s16(v) for v in _n(s.monitor_device_values, 3, 0)])


def encode_develop2(s: ReportSnapshot) -> bytes:
    """Firmware 2.x develop frame (port 30003), 135 bytes: the manual's 87 then F/T external and raw."""
    buf = bytearray(DEVELOP2_SIZE)
    _pack_develop(buf, s, DEVELOP2_SIZE)
    _FT2.pack_into(buf, OFF_DEVELOP_FT, *_n(s.ft_ext_force, 6), *_n(s.ft_raw_force, 6))
    return bytes(buf)


def encode_rich2(s: ReportSnapshot) -> bytes:
    """Firmware 2.x rich frame (port 30002), 587 bytes: the manual's 433 then bytes 433..586."""
    buf = _rich_frame(s, RICH2_SIZE)
    _pack_rich_tail(buf, s)
    return bytes(buf)


def encode_realtime(s: ReportSnapshot) -> bytes:
    """Real-time report (port 30000, ``FirmwareProfile.realtime_report``), 804 bytes.

    Targets and actual values are the same snapshot values; accelerations, currents and torques
    fill their blocks, reserved blocks are zero. IO values are in mV.
    """
    buf = bytearray(REALTIME_SIZE)
    _RT_HEAD.pack_into(buf, 0, REALTIME_SIZE, s.timestamp_us & 0xFFFFFFFFFFFFFFFF,
                       _state_byte(s.state, s.mode), s.cmdnum)
    j, v, a = _n(s.joints, 7), _n(s.joint_speeds, 7), _n(s.joint_accelerations, 7)
    _RT_JOINTS.pack_into(buf, OFF_RT_JOINTS, *j, *v, *a, *j, *v, *a, *_n(s.joint_currents, 7),
                         *_n(s.torques, 7))
    pose = [*_n(s.pose, 6)[:3], *_n(s.pose_aa, 3)]
    vel = _n(s.tcp_velocity, 6)
    _RT_TCP.pack_into(buf, OFF_RT_TCP, *pose, *vel, *pose, *vel, *_n(s.ft_ext_force, 6), *_Z6, *_Z6)
    _RT_FT.pack_into(buf, OFF_RT_FT, *_n(s.ft_raw_force, 6), *_n(s.ft_ext_force, 6))
    _RT_MON.pack_into(buf, OFF_RT_MON, s.monitor_device_type & 0xFF, s.monitor_device_state & 0xFF,
                      *[_s16(x) for x in _n(s.monitor_device_values, 3, 0)])
    ai = [_s16(x * 1000.0) for x in _n(s.analog_inputs, 2)]
    ao = [_s16(x * 1000.0) for x in _n(s.analog_outputs, 2)]
    _RT_IO.pack_into(buf, OFF_RT_IO, s.cgpio_input_config & 0xFFFF, s.cgpio_output_config & 0xFFFF,
                     *ai, *ao, 0, 0, 0, 0)
    return bytes(buf)


def _unpack_develop_ft(data: bytes, s: ReportSnapshot) -> None:
    v = _FT2.unpack_from(data, OFF_DEVELOP_FT)
    s.ft_ext_force, s.ft_raw_force = v[0:6], v[6:12]


def _unpack_rich_tail(data: bytes, s: ReportSnapshot) -> None:
    v = _FT2.unpack_from(data, OFF_RICH_TAIL)
    s.ft_ext_force, s.ft_raw_force = v[0:6], v[6:12]
    p, *aa, bits = _RICH_T1.unpack_from(data, 481)
    s.iden_progress, s.pose_aa = p, tuple(aa)
    s.report_current, s.approx_motion, s.cart_continuous = bool(bits & 4), bool(bits & 8), bool(bits & 16)
    on, *bound = _RICH_REDUCED.unpack_from(data, OFF_REDUCED)
    s.reduced_mode, s.reduced_tcp_boundary = bool(on), tuple(bound)
    f = _RICH_REDUCED_F.unpack_from(data, 508)
    s.reduced_max_tcp_speed, s.reduced_max_joint_speed = f[0], f[1]
    s.reduced_joint_ranges, s.fence, s.collision_rebound = f[2:16], bool(f[16]), bool(f[17])
    t = _RICH_T2.unpack_from(data, OFF_ALARM)
    s.cgpio_alarm, s.ft_enabled = t[0], bool(t[1] & 1)
    s.monitor_device_type, s.monitor_device_state, s.monitor_device_values = t[2], t[3], t[4:7]


def decode_develop2(data: bytes) -> ReportSnapshot:
    """Read a 135-byte firmware 2.x develop frame."""
    return _decode(data, DEVELOP2_SIZE, "develop (2.x)", (_unpack_develop, _unpack_develop_ft))


def decode_rich2(data: bytes) -> ReportSnapshot:
    """Read a 587-byte firmware 2.x rich frame."""
    return _decode(data, RICH2_SIZE, "rich (2.x)", (_unpack_develop, _unpack_normal, _unpack_rich,
                                                    _unpack_rich_tail))


def decode_realtime(data: bytes) -> ReportSnapshot:
    """Read an 804-byte real-time frame: state, mode, counter, timestamp, actual joints, pose, F/T."""
    _check(data, REALTIME_SIZE, "real-time")
    s = ReportSnapshot()
    _, s.timestamp_us, sm, s.cmdnum = _RT_HEAD.unpack_from(data, 0)
    s.state, s.mode = sm & 0x0F, sm >> 4
    j = _RT_JOINTS.unpack_from(data, OFF_RT_JOINTS)
    b = _RT_SLICES
    s.joints, s.joint_speeds, s.joint_accelerations = j[b["joints"]], j[b["joint_speeds"]], \
        j[b["joint_accelerations"]]
    s.joint_currents, s.torques = j[b["joint_currents"]], j[b["torques"]]
    t = _RT_TCP.unpack_from(data, OFF_RT_TCP)
    p = RT_TCP_POSITION
    s.pose_aa, s.tcp_velocity = t[p + 3:p + 6], t[p + 6:p + 12]
    s.pose = (*t[p:p + 3], *s.pose[3:])
    f = _RT_FT.unpack_from(data, OFF_RT_FT)
    s.ft_raw_force, s.ft_ext_force = f[0:6], f[6:12]
    m = _RT_MON.unpack_from(data, OFF_RT_MON)
    s.monitor_device_type, s.monitor_device_state, s.monitor_device_values = m[0], m[1], m[2:5]
    return s


Encoder = Callable[[ReportSnapshot], bytes]
Decoder = Callable[[bytes], ReportSnapshot]
#: The frames of a 2.x box by port (encoder, decoder); port 30000 where the profile has it.
_FW2_CODECS: dict[int, tuple[Encoder, Decoder]] = {
    DEVELOP_PORT: (encode_develop2, decode_develop2), NORMAL_PORT: (encode_normal, decode_normal),
    RICH_PORT: (encode_rich2, decode_rich2)}


def _codecs_for(profile: FirmwareProfile) -> dict[int, tuple[Encoder, Decoder]]:
    """Report port -> (encoder, decoder) for a box of ``profile``'s firmware."""
    if not profile.reports_2x:
        return {port: (ENCODERS[port], DECODERS[port]) for port in ENCODERS}
    out = dict(_FW2_CODECS)
    if profile.realtime_report:
        out[REALTIME_PORT] = (encode_realtime, decode_realtime)
    return out


def encoders_for(profile: FirmwareProfile) -> dict[int, Encoder]:
    """Report port -> encoder for a box of ``profile``'s firmware: the manual's frames for 1.x,
    the 135/145/587-byte frames plus port 30000 for 2.x."""
    return {port: enc for port, (enc, _) in _codecs_for(profile).items()}


def decoders_for(profile: FirmwareProfile) -> dict[int, Decoder]:
    """Report port -> decoder matching :func:`encoders_for`."""
    return {port: dec for port, (_, dec) in _codecs_for(profile).items()}


def rates_for(profile: FirmwareProfile) -> dict[int, float]:
    """Report port -> default frequency in Hz for ``profile``."""
    out = dict(RATES)
    if profile.realtime_report:
        out[REALTIME_PORT] = REALTIME_RATE
    return out
