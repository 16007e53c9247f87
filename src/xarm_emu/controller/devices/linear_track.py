"""The UFACTORY linear track (the SDK's "linear motor"): a seventh axis on the control box RS-485.

Register 124 (manual section 2.1.4) tunnels ``[host id][Modbus-RTU PDU]``; host 11 is the control
box RS-485, where the track's drive answers as slave :data:`TRACK_ID` (1) at 2,000,000 bps (baud
index 11 of register 127/128, address 0x0A0B on host 11). The SDK reads and writes u16 registers
with functions 0x03, 0x06 and 0x10 (big-endian; an s32 spans two registers, high word first):

=========  ======  ===========================================================================
address    access  meaning
=========  ======  ===========================================================================
0x0100     rw      enable (0/1)
0x0109     w       error clear (write 1)
0x0303     rw      speed, in mm/s x 6.667 (:data:`SPEED_UNITS`), 1..6667 (1..1000 mm/s)
0x0700     rw      target position, s32, mm x 2000 (:data:`PULSES_PER_MM`)
0x0801-3   r       drive firmware version major, minor, revision
0x0A0A     w       back to origin (write 1): homing
0x0A0E     w       stop (write 1): decelerate to rest
0x0A20     r       position, s32, mm x 2000
0x0A22     r       status: bit 0 in motion, bit 1 stopped by a stop command
0x0A23     r       error code (0 none; :data:`TRACK_ERRORS`)
0x0A24     r       enabled (bit 0)
0x0A25     r       on zero (bit 0): homed since power-on
0x0A26     r       SCI inputs: bit 1 is SCI1, high when the drive may run
0x0A27     r       SCO outputs: bits 0, 1
0x0B10-1D  r       serial number, one ASCII character per register (0x1B10-1D write it)
others     rw      drive parameters the SDK's default-parameter set writes (:data:`PARAMETERS`)
=========  ======  ===========================================================================

The SDK polls the status register every 0.1 s while it waits: ``set_linear_motor_pos(wait=True)``
returns when bit 0 falls, ``set_linear_motor_back_origin(wait=True)`` when "on zero" rises (10 s
timeout); either returns its fault code 80 when the error register is not 0, and 81 when SCI1 is
low. ``set_linear_motor_pos`` refuses with its code 82, before sending anything, while the track is
not on zero.

What the emulator assumes (the public material gives speed 1..1000 mm/s and strokes 700, 1000 and
1500 mm by serial number AL1300, AL1301, AL1302; nothing on acceleration or homing):

- the carriage follows a trapezoidal profile, re-planned every control period from where it is and
  how fast it goes, at the set speed and at accelerations of :data:`MAX_SPEED` per acceleration time
  (parameters 0x1300 and 0x1301, 300 ms each after power-on: 3333 mm/s^2), so a new target or a stop
  mid-move blends without a jump;
- homing runs to the origin switch at the homing speed (parameter 0x1404 in the speed register's
  units: 1533, 230 mm/s), then latches the switch for :data:`HOME_LATCH` seconds; it powers the
  drive (the SDK homes a disabled track and enables it afterwards). At power-on the carriage is where
  it was left (``position``), not on zero;
- refusals raise the drive's error, which stops the carriage and disables it: a target outside the
  stroke, code 25 (command over software limit); a speed outside 1..1000 mm/s, code 12 (speed
  overlimit); a target while disabled, code 13 (large position deviation: the unpowered motor cannot
  follow). A target before homing is ignored (the SDK never sends one). Error clear removes every
  code but 10 (current detection), which needs a restart;
- the box's emergency stop (C1) cuts the drive: the carriage stops and is disabled; it stays homed.

The arm's TCP pose in the reports and registers stays the arm's own, relative to its base on the
carriage: the SDK reads the track position only through these registers and never adds it to a pose.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

from ...protocol import regmap, rtu
from ..core.controller_state import holds
from ..core.interface import C_ESTOP, NOT_IDLE, ControllerView

TRACK_ID = 1  # the SDK's linear motor slave id on the control box RS-485
TRACK_BAUD_INDEX = 11  # 2,000,000 bps, the SDK's default baud for the track

#: Stroke (mm) of each model, by serial number prefix.
MODELS = {700: "AL1300", 1000: "AL1301", 1500: "AL1302"}
DEFAULT_LENGTH = 700

PULSES_PER_MM = 2000  # position registers: mm x 2000
SPEED_UNITS = 6.667  # speed register: mm/s x 6.667
MIN_SPEED = 1.0  # mm/s
MAX_SPEED = 1000.0  # mm/s
SPEED_VALUE_MIN = int(MIN_SPEED * SPEED_UNITS)  # 6
SPEED_VALUE_MAX = int(MAX_SPEED * SPEED_UNITS)  # 6667
#: Homing latches the origin switch this long after reaching it (s); the emulator's choice.
HOME_LATCH = 1.0
#: Below this distance (mm) the carriage counts as at its target.
AT_TARGET = 1e-6

# Register addresses.
REG_ENABLE = 0x0100
REG_CLEAR = 0x0109
REG_SPEED = 0x0303
REG_TARGET = 0x0700
REG_VERSION = 0x0801
REG_BACK_ORIGIN = 0x0A0A
REG_STOP = 0x0A0E
REG_POSITION = 0x0A20
REG_STATUS = 0x0A22
REG_ERROR = 0x0A23
REG_ENABLED = 0x0A24
REG_ON_ZERO = 0x0A25
REG_SCI = 0x0A26
REG_SCO = 0x0A27
REG_SN = 0x0B10
REG_SN_WRITE = 0x1B10
SN_LENGTH = 14

REG_ACC_TIME = 0x1300
REG_DEC_TIME = 0x1301
REG_HOME_SPEED = 0x1404
#: Drive parameters and their values after power-on: the set the SDK's
#: ``set_linear_motor_default_parmas`` writes (motor type, power level, filters, loop gains,
#: acceleration and deceleration times in ms, speed limit, homing speed, positioning window, ...).
#: They are stored and read back; only the acceleration times and the homing speed act on motion.
PARAMETERS: dict[int, int] = {
    0x1804: 610, 0x1901: 1, 0x0501: 0, 0x1200: 250, 0x1202: 5, 0x1203: 200, 0x1204: 150,
    REG_ACC_TIME: 300, REG_DEC_TIME: 300, 0x1302: 10, 0x1401: 160, 0x1402: 160, 0x1403: 10000,
    REG_HOME_SPEED: 1533, 0x190C: 6000, 0x190D: 1000, 0x1A0A: 0, 0x1A0B: TRACK_BAUD_INDEX,
    0x1A0D: 1800, 0x1A0E: 0, 0x1A25: 0,
}

# Drive error codes, as the SDK's linear motor error table numbers them.
E_CURRENT_DETECTION = 10
E_CURRENT_OVERLIMIT = 11
E_SPEED_OVERLIMIT = 12
E_POSITION_DEVIATION = 13
E_POSITION_COMMAND_OVERLIMIT = 14
E_DRIVER_IC_HARDWARE = 20
E_DRIVER_IC_INIT = 21
E_SOFT_LIMIT = 25
E_FEEDBACK_SOFT_LIMIT = 26
E_DRIVE_OVERLOADED = 33
E_MOTOR_OVERLOAD = 34
E_MOTOR_TYPE = 35
E_DRIVER_TYPE = 36
E_OVER_VOLTAGE = 39
E_UNDER_VOLTAGE = 40
E_EEPROM = 49
#: Every drive error code with a short name (``inject track-error CODE``).
TRACK_ERRORS: dict[int, str] = {
    E_CURRENT_DETECTION: "current detection", E_CURRENT_OVERLIMIT: "current overlimit",
    E_SPEED_OVERLIMIT: "speed overlimit", E_POSITION_DEVIATION: "large position deviation",
    E_POSITION_COMMAND_OVERLIMIT: "position command overlimit",
    E_DRIVER_IC_HARDWARE: "driver IC hardware", E_DRIVER_IC_INIT: "driver IC initialization",
    E_SOFT_LIMIT: "command over software limit", E_FEEDBACK_SOFT_LIMIT: "feedback over software limit",
    E_DRIVE_OVERLOADED: "drive overloaded", E_MOTOR_OVERLOAD: "motor overload",
    E_MOTOR_TYPE: "motor type", E_DRIVER_TYPE: "driver type", E_OVER_VOLTAGE: "over voltage",
    E_UNDER_VOLTAGE: "under voltage", E_EEPROM: "EEPROM read/write",
}
#: Codes error clear does not remove: the drive needs a restart.
NEEDS_RESTART = frozenset({E_CURRENT_DETECTION})

STATUS_MOVING = 0x01
STATUS_STOPPED = 0x02


def plan_move(x: float, v: float, goal: float, vmax: float, acc: float,
              dec: float) -> list[tuple[float, float, float, float]]:
    """The trapezoidal profile from ``x`` mm at ``v`` mm/s to rest at ``goal``: phases of (duration
    s, start mm, start mm/s, acceleration mm/s^2). Moving away from the goal, or too fast to stop
    before it, it first brakes to rest; above ``vmax`` it first slows to it."""
    phases: list[tuple[float, float, float, float]] = []

    def add(duration: float, a: float) -> None:
        nonlocal x, v
        if duration > 0.0:
            phases.append((duration, x, v, a))
            x += v * duration + 0.5 * a * duration * duration
            v += a * duration

    d = goal - x
    if v != 0.0 and (d * v < 0.0 or v * v / (2.0 * dec) > abs(d) + AT_TARGET):
        add(abs(v) / dec, -math.copysign(dec, v))
        v, d = 0.0, goal - x
    if v == 0.0 and abs(d) <= AT_TARGET:
        return phases
    sign = math.copysign(1.0, v if v != 0.0 else d)
    if abs(v) > vmax:
        add((abs(v) - vmax) / dec, -sign * dec)
    u, dist = abs(v), abs(goal - x)
    peak = min(vmax, math.sqrt(max(u * u, (2.0 * acc * dec * dist + dec * u * u) / (acc + dec))))
    cruise = dist - (peak * peak - u * u) / (2.0 * acc) - peak * peak / (2.0 * dec)
    add((peak - u) / acc, sign * acc)
    add(max(0.0, cruise) / peak, 0.0)
    add(peak / dec, -sign * dec)
    return phases


def check_length(length: int) -> int:
    """The stroke in mm if a track of that length exists (700, 1000, 1500), else ValueError."""
    if length not in MODELS:
        raise ValueError(f"a linear track is {', '.join(map(str, MODELS))} mm long, not {length}")
    return length


@dataclass(slots=True)
class LinearTrackState:
    """Every mutable value of the track's drive (power-on values: :class:`LinearTrack`)."""

    position: float = 0.0  # mm
    velocity: float = 0.0  # mm/s
    target: float = 0.0  # mm
    enabled: bool = False
    on_zero: bool = False
    homing: str = ""  # "" | "travel" (to the switch) | "latch"
    latch_left: float = 0.0
    error: int = 0
    stopped: bool = False
    speed_value: int = 0
    sci: int = 0
    sco: list[int] = field(default_factory=lambda: [0, 0])
    parameters: dict[int, int] = field(default_factory=dict)
    target_words: list[int] = field(default_factory=lambda: [0, 0])
    plan: list[tuple[float, float, float, float]] = field(default_factory=list)
    plan_time: float = 0.0
    plan_goal: float = 0.0


@holds(LinearTrackState)
class LinearTrack:
    """The track's drive: a Modbus slave (:class:`rtu.RegisterDevice`) and a controller component
    whose carriage moves in :meth:`step`. Its changing values are one :class:`LinearTrackState`
    (``self.data``); the length, version and serial number are fixed."""

    REGISTER_MAP: ClassVar[regmap.RegisterMap]  # below the class

    def __init__(self, length: int = DEFAULT_LENGTH, *, position: float = 0.0,
                 version: tuple[int, int, int] = (1, 0, 0), sn: str | None = None) -> None:
        self.data = LinearTrackState()
        self.length = check_length(length)
        if not 0.0 <= position <= length:
            raise ValueError(f"carriage position {position} mm outside the stroke 0..{length}")
        self.version = version
        self.sn = (sn or f"{MODELS[length]}0000000001")[:SN_LENGTH].ljust(SN_LENGTH, "0")
        self.position = float(position)  # mm
        self.velocity = 0.0  # mm/s
        self.target = float(position)  # mm
        self.enabled = False
        self.on_zero = False
        self.homing = ""  # "" | "travel" (to the switch) | "latch"
        self.latch_left = 0.0
        self.error = 0
        self.stopped = False
        self.speed_value = 5000  # the default-parameter speed: 750 mm/s
        self.sci = 1
        self.sco = [0, 0]
        self.parameters = dict(PARAMETERS)
        self.target_words = [0, 0]
        #: The carriage's motion: phases (duration s, start mm, start mm/s, acceleration mm/s^2)
        #: from the last command, ``plan_time`` into them, ending at rest at ``plan_goal``.
        self.plan: list[tuple[float, float, float, float]] = []
        self.plan_time = 0.0
        self.plan_goal = self.position

    # --- state -------------------------------------------------------------------------------------

    @property
    def speed(self) -> float:
        """The set speed, mm/s."""
        return self.speed_value / SPEED_UNITS

    @property
    def acceleration(self) -> float:
        return MAX_SPEED / (max(1, self.parameters[REG_ACC_TIME]) / 1000.0)

    @property
    def deceleration(self) -> float:
        return MAX_SPEED / (max(1, self.parameters[REG_DEC_TIME]) / 1000.0)

    @property
    def home_speed(self) -> float:
        return max(1, self.parameters[REG_HOME_SPEED]) / SPEED_UNITS

    @property
    def moving(self) -> bool:
        return bool(self.homing) or bool(self.plan)

    @property
    def status(self) -> int:
        return (STATUS_MOVING if self.moving else 0) | (STATUS_STOPPED if self.stopped else 0)

    @property
    def position_pulses(self) -> int:
        return int(round(self.position * PULSES_PER_MM))

    def _halt(self) -> None:
        self.velocity = 0.0
        self.target = self.position
        self.plan = []
        self.homing = ""

    def inject_error(self, code: int) -> None:
        """Raise a drive error: the carriage stops at once and the drive is disabled."""
        if code not in TRACK_ERRORS:
            known = ", ".join(str(c) for c in TRACK_ERRORS)
            raise ValueError(f"linear track error code {code}: one of {known}")
        self.error = code
        self.enabled = False
        self._halt()

    def clear_error(self) -> None:
        if self.error not in NEEDS_RESTART:
            self.error = 0

    def status_fields(self) -> dict[str, Any]:
        return {"position_mm": round(self.position, 3), "enabled": self.enabled, "on_zero": self.on_zero,
                "moving": self.moving}

    # --- commands ----------------------------------------------------------------------------------

    def set_enable(self, on: int) -> None:
        if on not in (0, 1):
            raise rtu.RtuError(rtu.ILLEGAL_VALUE)
        if on and self.error:
            return  # an error keeps the drive off until cleared
        self.enabled = bool(on)
        if not on:
            self._halt()

    def set_speed(self, value: int) -> None:
        if not SPEED_VALUE_MIN <= value <= SPEED_VALUE_MAX:
            self.inject_error(E_SPEED_OVERLIMIT)
            return
        self.speed_value = value
        if self.plan and not self.homing:
            self._replan(self.target, self.speed)

    def set_target(self, pulses: int) -> None:
        mm = pulses / PULSES_PER_MM
        if not 0.0 <= mm <= self.length:
            self.inject_error(E_SOFT_LIMIT)
        elif self.error or not self.on_zero or self.homing:
            return
        elif not self.enabled:
            self.inject_error(E_POSITION_DEVIATION)
        else:
            self.target = mm
            self.stopped = False
            self._replan(mm, self.speed)

    def back_origin(self) -> None:
        if self.error:
            return
        self.enabled = True
        self.on_zero = False
        self.stopped = False
        self.homing = "travel"
        self._replan(0.0, self.home_speed)

    def stop(self) -> None:
        """Decelerate to rest: the target becomes where the carriage can stop (between where it is and
        the old target, so inside the stroke)."""
        self.homing = ""
        v = self.velocity
        self.target = self.position + math.copysign(v * v / (2.0 * self.deceleration), v)
        self._replan(self.target, MAX_SPEED)
        self.stopped = True

    # --- Modbus slave ------------------------------------------------------------------------------

    def read_registers(self, address: int, count: int) -> list[int]:
        return regmap.read_registers(REGISTER_MAP, self, address, count)

    def write_registers(self, address: int, values: Sequence[int]) -> None:
        regmap.write_registers(REGISTER_MAP, self, address, values)

    # --- motion ------------------------------------------------------------------------------------

    def _replan(self, goal: float, vmax: float) -> None:
        self.plan = plan_move(self.position, self.velocity, goal, vmax, self.acceleration,
                              self.deceleration)
        self.plan_time = 0.0
        self.plan_goal = goal

    def _travel(self, dt: float) -> bool:
        """One control period along the plan; True once the carriage is at the plan's goal at rest."""
        if not self.plan:
            self.velocity = 0.0
            return True
        self.plan_time += dt
        t = self.plan_time
        for duration, x0, v0, a in self.plan:
            if t <= duration:
                self.position = x0 + v0 * t + 0.5 * a * t * t
                self.velocity = v0 + a * t
                return False
            t -= duration
        self.position, self.velocity, self.plan = self.plan_goal, 0.0, []
        return True

    def step(self, dt: float, ctl: ControllerView) -> None:
        """Advance the carriage by one control period (the trapezoid at the set speed, or homing)."""
        if ctl.error_code == C_ESTOP and self.enabled:
            self.enabled = False
            self._halt()
        if self.error or not self.enabled:
            self.velocity = 0.0
            return
        if self.homing == "latch":
            self.latch_left -= dt
            if self.latch_left <= 1e-9:
                self.homing = ""
                self.on_zero = True
                self.position = self.target = 0.0
            return
        if self._travel(dt) and self.homing == "travel":
            self.homing = "latch"
            self.latch_left = HOME_LATCH
            self.target = 0.0

    def idle_until(self, ctl: ControllerView) -> float:
        """Idle (:func:`~..core.interface.idle_until`) while the carriage rests: no move, no homing, and no
        emergency stop left to cut the drive."""
        if self.moving or self.velocity != 0.0 or (ctl.error_code == C_ESTOP and self.enabled):
            return NOT_IDLE
        return math.inf


# --- the drive's registers ---------------------------------------------------------------------------


def _on_one(t: LinearTrack, value: int, *, action: str) -> None:
    """A command register: writing 1 runs the action, any other value does nothing."""
    if value == 1:
        getattr(t, action)()


def _put_target_word(t: LinearTrack, value: int, *, word: int) -> None:
    t.target_words[word] = value


def _commit_target(t: LinearTrack) -> None:
    """The target registers written by one request (a word not written keeps its last value)."""
    t.set_target(rtu.words_s32(*t.target_words))


def _sci(t: LinearTrack) -> int:
    return (t.sci & 1) << 1


def _sco(t: LinearTrack) -> int:
    return (t.sco[0] & 1) | (t.sco[1] & 1) << 1


def _sn_char(t: LinearTrack, *, index: int) -> int:
    return ord(t.sn[index])


def _write_sn_char(t: LinearTrack, value: int, *, index: int) -> None:
    t.sn = t.sn[:index] + chr(value & 0x7F) + t.sn[index + 1:]


#: The drive's registers (module docstring): commands, state, version, serial number (read at 0x0B10,
#: written at 0x1B10) and the stored drive parameters (:data:`PARAMETERS`).
REGISTER_MAP: dict[int, regmap.Reg] = {
    REG_ENABLE: regmap.Reg("enabled", "rw", put=LinearTrack.set_enable, range=(0, 1)),
    REG_CLEAR: regmap.Reg("clear_error", "w", put=functools.partial(_on_one, action="clear_error")),
    # Outside 1..SPEED_VALUE_MAX the drive raises its speed error itself (set_speed), no exception.
    REG_SPEED: regmap.Reg("speed_value", "rw", put=LinearTrack.set_speed, scale=1 / SPEED_UNITS,
                          unit="mm/s"),
    **regmap.s32(REG_TARGET, "target", counts=PULSES_PER_MM, unit="mm", access="rw",
                 put=_put_target_word, commit=_commit_target),
    **regmap.items(REG_VERSION, "version", 3),
    REG_BACK_ORIGIN: regmap.Reg("back_origin", "w", put=functools.partial(_on_one, action="back_origin")),
    REG_STOP: regmap.Reg("stop", "w", put=functools.partial(_on_one, action="stop")),
    **regmap.s32(REG_POSITION, "position", counts=PULSES_PER_MM, unit="mm"),
    REG_STATUS: regmap.Reg("status"),
    REG_ERROR: regmap.Reg("error"),
    REG_ENABLED: regmap.Reg("enabled"),
    REG_ON_ZERO: regmap.Reg("on_zero"),
    REG_SCI: regmap.Reg("sci", get=_sci),
    REG_SCO: regmap.Reg("sco", get=_sco),
    **{REG_SN + i: regmap.Reg(f"sn[{i}]", get=functools.partial(_sn_char, index=i))
       for i in range(SN_LENGTH)},
    **{REG_SN_WRITE + i: regmap.Reg(f"sn[{i}]", "w", put=functools.partial(_write_sn_char, index=i))
       for i in range(SN_LENGTH)},
    **regmap.entries("parameters", PARAMETERS, access="rw"),
}
LinearTrack.REGISTER_MAP = REGISTER_MAP
