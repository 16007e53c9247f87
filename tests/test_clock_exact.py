"""The stepped clock's jump over idle control periods (controller/emulator.py ``Emulator.step``)
changes nothing anyone can observe: the same program run with the jump and with every period
stepped one by one (``Emulator(exact_steps=True)``) gives the same report bytes (develop, normal,
rich; manual 2.1.6), the same register replies, the same clock and the same temperatures at every
instant a report or a command could look, for firmware 1.6.0 and 2.7.103."""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from helpers import report_frames, step_both
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xarm_emu.controller.core.feedback import feedback_queue
from xarm_emu.controller.devices import gripper as grip
from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import rtu
from xarm_emu.protocol.rtu import TOOL_HOST

FIRMWARES = ("1.6.0", "2.7.103")
#: Parameterless reads: version, serial, state, cmdnum, errors, poses, torques, IO, reduced mode,...
READS = (1, 2, 5, 7, 8, 13, 14, 15, 41, 49, 53, 55, 57, 65, 67, 69, 91, 106, 125, 131, 132, 133, 139,
         140, 141)
TOOL_READS = (0x0A14, 0x0A16, 0x0A18)  # register 128: tool inputs, analog input, outputs read back

Action = Callable[[Emulator], object]


def send(emu: Emulator, code: int, **values: Any) -> tuple[int, bytes]:
    reg = emu.controller.registers[code]
    return emu.handle(code, reg.request.encode(values))


def rtu_call(emu: Emulator, pdu: bytes) -> tuple[int, bytes]:
    """Register 124: one Modbus-RTU request to the gripper on the tool RS-485 (as the SDK sends)."""
    return emu.handle(124, bytes([TOOL_HOST]) + pdu)


def gripper_to(emu: Emulator, pulse: int, speed: int = 3000) -> None:
    """Enable the gripper, set its speed, send it to ``pulse`` (the SDK's frames)."""
    rtu_call(emu, rtu.write_multiple_request(grip.GRIPPER_ID, grip.REG_ENABLE, (1,)))
    rtu_call(emu, rtu.write_multiple_request(grip.GRIPPER_ID, grip.REG_SPEED, (speed,)))
    rtu_call(emu, rtu.write_multiple_request(grip.GRIPPER_ID, grip.REG_TARGET,
                                             struct.unpack(">HH", struct.pack(">i", pulse))))


def observe(emu: Emulator) -> tuple[Any, ...]:
    """Everything a client can see now: every report frame, the replies of the reads, the clock
    (to the bit) and the thermal state behind the rich report's temperatures."""
    frames = report_frames(emu)
    regs = emu.controller.registers
    replies = tuple(emu.handle(code, b"") for code in READS if code in regs)
    tool = tuple(send(emu, 128, host=TOOL_HOST, addr=a) for a in TOOL_READS)
    pulses = rtu_call(emu, rtu.read_request(grip.GRIPPER_ID, grip.REG_POSITION, 2))
    return (frames, replies, tool, pulses, emu.time.hex(), emu.controller.steps,
            emu.thermal.temperatures.tobytes(), emu.io.time().hex())


def run_both(firmware: str, script: dict[int, list[Action]], total: int, pattern: tuple[int, ...],
             setup: Action | None = None, model: int | str = 6, vacuum: bool = False) -> tuple[int, Emulator]:
    """Run ``script`` (period count -> actions before stepping on) on a jumping and an exact emulator,
    comparing what both show at every instant; returns the instants compared and the jumping one."""
    fast = Emulator(model, firmware=firmware, vacuum=vacuum)
    exact = Emulator(model, firmware=firmware, vacuum=vacuum, exact_steps=True)
    if setup is not None:
        for emu in (fast, exact):
            setup(emu)
    instants = step_both(fast, exact, script, total, pattern, observe)
    return instants, fast


def ready(emu: Emulator) -> None:
    for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": 0}), (12, {"state": 0})):
        send(emu, code, **values)


def schedule_faults(emu: Emulator) -> None:
    """Scheduled actions (``Emulator.at``) at times between control periods and on them."""
    emu.at(3.0015, lambda: emu.inject_warning(12))
    emu.at(9.2, lambda: emu.set_input("cgpio", 3, 0))
    emu.at(17.777, lambda: emu.inject_error(31))
    emu.at(17.777, lambda: emu.set_input("tool-analog", 0, 1.5))
    emu.at(40.0, lambda: emu.set_input("tgpio", 0, 1))


PI = math.pi
MIXED: dict[int, list[Action]] = {
    0: [ready,
        lambda e: send(e, 23, joints=(0.4, 0.1, -0.3, 0.0, 0.2, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0),
        lambda e: send(e, 21, pose=(300.0, -50.0, 200.0, PI, 0.0, 0.0), speed=150.0, acc=2000.0, mvtime=0.0),
        lambda e: send(e, 26, seconds=0.75),
        lambda e: send(e, 27, pose1=(330.0, 0.0, 200.0, PI, 0.0, 0.0),
                       pose2=(300.0, 50.0, 230.0, PI, 0.0, 0.0), speed=150.0, acc=2000.0, mvtime=0.0,
                       percent=120.0),
        lambda e: send(e, 144, ionum=2, on=1, xyz=(330.0, 0.0, 200.0), tol_r=15.0),
        lambda e: send(e, 142, ionum=5, on=1, delay=6.5),
        lambda e: gripper_to(e, 600)],
    1250: [lambda e: send(e, 25, speed=1.0, acc=8.0, mvtime=0.0),
           lambda e: send(e, 143, ionum=1, on=1, delay=2.0)],
    # error C31 at 17.777 s (scheduled); cleared and re-enabled at 20 s, then one more move
    5000: [lambda e: send(e, 16), ready,
           lambda e: send(e, 23, joints=(-0.3, 0.2, -0.2, 0.0, 0.0, 0.0, 0.0), speed=1.5, acc=10.0,
                          mvtime=0.0)],
    6250: [lambda e: send(e, 12, state=3)],  # suspend the dwell that follows
    6300: [lambda e: send(e, 26, seconds=2.0)],
    6500: [lambda e: send(e, 12, state=0)],
}


@pytest.mark.parametrize("firmware", FIRMWARES)
def test_mixed_program_identical_at_every_report_instant(firmware: str) -> None:
    """Joint, linear and circular moves, a dwell, IO by time and by position, the gripper, a warning
    and an error on a schedule: at every 100 Hz develop report instant (2 and 3 periods apart) and
    at larger strides."""
    instants, fast = run_both(firmware, MIXED, 45 * 250, (2, 3) * 100 + (250, 1, 1000, 37),
                              setup=schedule_faults)
    assert instants > 1000
    assert fast.periods_jumped > 0.4 * fast.controller.steps  # the jump did run, most of the idle time
    assert fast.controller.error_code == 0 and fast.io.cgpio.output(5) == 1 and fast.io.cgpio.output(2) == 1


IDLE: dict[int, list[Action]] = {
    0: [ready,
        lambda e: send(e, 23, joints=(0.0, -0.3, -0.4, 0.0, 0.7, 0.0, 0.0), speed=1.0, acc=8.0, mvtime=0.0),
        lambda e: send(e, 142, ionum=1, on=1, delay=12.345),
        lambda e: send(e, 143, ionum=0, on=1, delay=31.0)],
    7500: [lambda e: gripper_to(e, 300, speed=1000)],
    10000: [lambda e: send(e, 16), ready],
}


@pytest.mark.parametrize("firmware", FIRMWARES)
def test_mostly_idle_program_identical(firmware: str) -> None:
    """One move, then 60 s of rest with delayed outputs and scheduled faults, looked at in strides
    from one period to 40 s: the jump covers nearly all of it and changes nothing."""
    pattern = (1, 2, 3, 25, 250, 4, 7, 2, 3, 2, 3, 500, 1000, 4000)
    instants, fast = run_both(firmware, IDLE, 60 * 250, pattern, setup=schedule_faults)
    assert instants > 30
    assert fast.periods_jumped > 0.9 * fast.controller.steps
    # CO1 fired at 12.345 s; TO0, due at 31 s, was dropped by the error at 17.777 s (state 4)
    assert fast.io.cgpio.output(1) == 1 and fast.io.tool.output(0) == 0
    assert fast.thermal.temperatures.max() > 25.0  # the arm held against gravity warmed up


@pytest.mark.parametrize("firmware", FIRMWARES)
def test_dwell_identical(firmware: str) -> None:
    """A 30 s dwell (register 26) between two moves, suspended and resumed on the way (register 12):
    the dwell's periods are jumped over, the move after it starts on the same period."""
    script: dict[int, list[Action]] = {
        0: [ready, lambda e: send(e, 26, seconds=30.0),
            lambda e: send(e, 23, joints=(0.3, 0.0, -0.2, 0.0, 0.2, 0.0, 0.0), speed=1.0, acc=8.0,
                           mvtime=0.0)],
        2500: [lambda e: send(e, 12, state=3)], 3000: [lambda e: send(e, 12, state=0)]}
    _, fast = run_both(firmware, script, 40 * 250, (3, 2, 700, 1, 1900),
                       setup=lambda e: e.at(7.0021, lambda: e.inject_warning(12)))
    assert fast.periods_jumped > 0.8 * fast.controller.steps
    assert fast.controller.executor.completed == 2


def servo_mode(emu: Emulator) -> None:
    for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": 1}), (12, {"state": 0})):
        send(emu, code, **values)


def servoj(q: tuple[float, ...]) -> Action:
    return lambda e: send(e, 29, joints=(*q, 0.0), speed=0.0, acc=0.0, mvtime=0.0)


@pytest.mark.parametrize("firmware", FIRMWARES)
def test_servo_hold_identical(firmware: str) -> None:
    """Servo mode (register 29) holding its target is jumped over; a safety boundary (registers 52,
    59) set that leaves the held pose outside stops it with C35 either way."""
    script: dict[int, list[Action]] = {0: [servo_mode]}
    for k in range(1, 60):  # a 250 Hz stream for a quarter of a second, then one far target
        script[k] = [servoj((0.004 * k, 0.002 * k, -0.003 * k, 0.0, 0.003 * k, 0.0))]
    script[60] = [servoj((0.6, 0.1, -0.4, 0.0, 0.3, 0.0))]
    script[3000] = [lambda e: send(e, 52, boundary=(100, 50, 100, 50, 100, 50)),
                    lambda e: send(e, 59, on=1)]
    _, fast = run_both(firmware, script, 20 * 250, (1, 3, 2, 300, 1, 2000))
    assert fast.periods_jumped > 0.6 * fast.controller.steps
    assert fast.controller.error_code == 35


def test_exact_steps_switch_steps_every_period() -> None:
    """``exact_steps`` runs every period; without it an idle arm jumps every period of a batch that
    comes before ``next_event()``, the last one too."""
    exact, fast = Emulator(6, exact_steps=True), Emulator(6)
    for emu in (exact, fast):
        emu.step(1)  # the first period at power-on runs: the IO has yet to see the motion state
        emu.step(25)
    assert exact.periods_jumped == 0
    assert fast.periods_jumped == 25 and fast.controller.steps == 26


def test_component_without_idle_method_is_stepped_every_period() -> None:
    """A component that cannot say it is idle (no ``idle_until``) gets every period, as before."""
    seen: list[float] = []

    class Ticker:
        def handlers(self) -> dict[int, Any]:
            return {}

        def step(self, dt: float, ctl: Any) -> None:
            seen.append(ctl.time)

    emu = Emulator(6)
    emu.controller.add_component(Ticker())
    emu.step(100)
    assert len(seen) == 100 and emu.periods_jumped == 0


def test_thermal_jump_bit_identical_over_a_quarter_hour() -> None:
    """A quarter of an hour at rest in one call: the temperatures (rich report bytes 246-252) equal
    those of 900 one-second thermal steps run period by period, to the bit."""
    fast, exact = Emulator(6), Emulator(6, exact_steps=True)
    for emu in (fast, exact):
        ready(emu)
        send(emu, 23, joints=(0.0, -0.5, -0.5, 0.0, 0.9, 0.0, 0.0), speed=2.0, acc=10.0, mvtime=0.0)
        emu.step(500)
    fast.step(900 * 250)
    exact.step(900 * 250)
    assert fast.thermal.temperatures.tobytes() == exact.thermal.temperatures.tobytes()
    assert fast.time.hex() == exact.time.hex()
    assert observe(fast) == observe(exact)


def with_feedback(emu: Emulator) -> None:
    """Firmware 2.x feedback (registers 253/254) as the server wires it: every command through the
    feedback queue of connection 1, which asked for every feedback type."""
    fb = feedback_queue(emu.controller)
    handle = emu.handle
    tid = [0]

    def through_queue(code: int, params: bytes) -> tuple[int, bytes]:
        tid[0] += 1
        fb.begin(emu.controller, 1, tid[0], 2, code)
        state = 0
        try:
            state, reply = handle(code, params)
        finally:
            fb.end(emu.controller, state)
        return state, reply

    emu.handle = through_queue  # type: ignore[method-assign]
    through_queue(254, bytes([0xFF]))
    schedule_faults(emu)


def test_feedback_frames_identical() -> None:
    """With feedback on (firmware 2.7.103), the motion start and finish and trigger events come out
    the same, with the same controller times, and idle periods are still jumped over."""
    events: dict[str, list[bytes]] = {"fast": [], "exact": []}

    def drain(e: Emulator) -> None:
        fb = feedback_queue(e.controller)
        events["exact" if e.exact_steps else "fast"].extend(ev.encode() for ev in fb.drain())

    script = {k: list(v) for k, v in MIXED.items()}
    for mark in range(0, 45 * 250, 50):
        script.setdefault(mark, []).append(drain)
    _, fast = run_both("2.7.103", script, 45 * 250, (2, 3, 250, 1, 37), setup=with_feedback)
    assert events["fast"] == events["exact"] and len(events["fast"]) > 10
    assert fast.periods_jumped > 0.3 * fast.controller.steps


def tool_outputs(word: int) -> Action:
    """Register 127: the tool output word (0x0A15, the SDK's ``tgpio_set_digital`` mask form)."""
    return lambda e: send(e, 127, host=TOOL_HOST, addr=0x0A15, value=float(word), sync=0)


def test_end_tools_identical() -> None:
    """The vacuum gripper's pressure switch (TI0, its pump started by a delayed TO0) and the Lite 6
    gripper's jaws (TO0/TO1) follow their outputs the same way with and without the jump."""
    pump = {0: [ready, lambda e: send(e, 143, ionum=0, on=1, delay=1.0)], 500: [tool_outputs(0x0302)],
            900: [lambda e: e.set_input("vacuum-object", 0, 0)], 1000: [tool_outputs(0x0301)]}
    _, fast = run_both("1.6.0", pump, 1500, (2, 3, 100, 1, 400), vacuum=True)
    assert fast.periods_jumped > 0.5 * fast.controller.steps
    jaws = {0: [ready, tool_outputs(0x0302)], 300: [tool_outputs(0x0301)], 340: [tool_outputs(0x0300)],
            700: [tool_outputs(0x0302)]}
    _, fast = run_both("2.7.103", jaws, 1200, (2, 3, 60, 1, 300), model="lite6")
    assert fast.lite6_gripper is not None and fast.lite6_gripper.jaw == "closed"
    assert fast.periods_jumped > 0.3 * fast.controller.steps


JOINTS = st.tuples(*(st.floats(-0.5, 0.5, allow_nan=False) for _ in range(6)))
OPS = st.one_of(
    st.tuples(st.just("move"), JOINTS),
    st.tuples(st.just("dwell"), st.floats(0.0, 1.0)),
    st.tuples(st.just("delayed"), st.integers(0, 7), st.floats(0.0, 3.0)),
    st.tuples(st.just("warning"), st.floats(0.0, 4.0)),
    st.tuples(st.just("error"), st.floats(0.0, 4.0)),
    st.tuples(st.just("clean"),),
    st.tuples(st.just("gripper"), st.integers(0, 850)),
)


def apply(op: tuple[Any, ...]) -> Action:
    kind = op[0]
    if kind == "move":
        return lambda e: send(e, 23, joints=(*op[1], 0.0), speed=2.0, acc=15.0, mvtime=0.0)
    if kind == "dwell":
        return lambda e: send(e, 26, seconds=op[1])
    if kind == "delayed":
        return lambda e: send(e, 142, ionum=op[1], on=1, delay=op[2])
    if kind == "warning":
        return lambda e: e.at(e.time + op[1], lambda: e.inject_warning(11))
    if kind == "error":
        return lambda e: e.at(e.time + op[1], lambda: e.inject_error(31))
    if kind == "gripper":
        return lambda e: gripper_to(e, op[1])
    return lambda e: (send(e, 16), ready(e))


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ops=st.lists(st.tuples(st.integers(0, 600), OPS), min_size=1, max_size=6),
       pattern=st.lists(st.integers(1, 400), min_size=1, max_size=5))
def test_random_programs_identical(ops: list[tuple[int, tuple[Any, ...]]], pattern: list[int]) -> None:
    """Random short programs (moves, dwells, delayed outputs, scheduled warnings and errors,
    recovery, the gripper), looked at in random strides: both ways agree at every instant."""
    script: dict[int, list[Action]] = {0: [ready]}
    for at, op in ops:
        script.setdefault(at, []).append(apply(op))
    run_both("1.6.0", script, 1000, tuple(pattern))


def test_observe_sees_a_difference() -> None:
    """The comparison can fail: one period more, or a temperature off by one ulp, shows."""
    a, b = Emulator(6), Emulator(6)
    a.step(10)
    b.step(11)
    assert observe(a) != observe(b)
    b = Emulator(6)
    b.step(10)
    assert observe(a) == observe(b)
    b.thermal._temps = np.nextafter(b.thermal._temps, np.inf)
    assert observe(a) != observe(b)


def test_a_long_jump_taken_in_chunks_is_the_jump_period_by_period(monkeypatch: pytest.MonkeyPatch) -> None:
    """Jumps of many periods sum the time (and a dwell's path time) a chunk at a time and run the
    thermal steps that fall due in between: the clock, the period count, the dwell and the
    temperatures come out bit for bit as when every jumped period is summed alone, for jumps that
    end on a scheduled action, a dwell's end, a batch's last period or a move."""
    from xarm_emu.controller.core import jump

    def run() -> list[tuple[Any, ...]]:
        emu = Emulator(6)
        for code, values in ((11, {"joint": 8, "enable": 1}), (19, {"mode": 0}), (12, {"state": 0})):
            send(emu, code, **values)
        emu.at(3.3337, lambda: send(emu, 26, seconds=11.1))  # a dwell, jumped over until its end
        emu.at(21.0, lambda: send(emu, 23, angles=(0.3, -0.2, -0.4, 0.0, 0.5, 0.0, 0.0), speed=0.5,
                                     acc=5.0, mvtime=0.0))
        emu.at(87.654, lambda: None)
        seen = []
        sizes = np.random.default_rng(3).integers(1, 3000, 60).tolist()
        for n in (1, 63, 64, 65, 250, 251, 700, 5000, 2, 30000, 17, 9000, *sizes):
            emu.step(n)
            d = emu.controller.data
            seen.append((d.time, d.steps, d.motion.t, d.q.tobytes(), emu.thermal.temperatures.tobytes(),
                         emu.periods_jumped))
        return seen

    chunked = run()
    monkeypatch.setattr(jump, "CHUNK", 1)  # every jumped period summed alone
    assert run() == chunked
    assert chunked[-1][5] > 30000  # most periods were jumped
