"""Every report frame is sampled fresh at its own deadline (manual 2.1.6: the box sends its state
every 10 ms on 30003, every 200 ms on 30001/30002): while the arm moves, no frame repeats the bytes
of the frame before it, and a blended corner never looks like a stop."""

from __future__ import annotations

import math
import socket
import threading
import time
from typing import Any

import pytest
from helpers import read_frames, sdk_ready

from xarm_emu.protocol import reports

HEAD = 12  # length, state/mode, cmdnum, then the six-floats blocks start after the first 12 bytes


class _Reader(threading.Thread):
    """Every whole frame of one report port, with its arrival time, until stopped."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True, name="test-report-reader")
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=2)
        self.frames: list[tuple[float, bytes]] = []
        self.stop = threading.Event()

    def run(self) -> None:
        self.frames = read_frames(self.sock, math.inf, stop=self.stop.is_set)

    def close(self) -> None:
        self.stop.set()
        self.join(2)
        self.sock.close()


def _moving(frames: list[bytes]) -> list[tuple[bytes, bytes]]:
    """Pairs of consecutive frames taken while the arm moves (state 1, develop byte 4)."""
    return [(a, b) for a, b in zip(frames, frames[1:], strict=False)
            if a[4] & 0x0F == 1 and b[4] & 0x0F == 1]


@pytest.mark.parametrize("firmware", ["1.6.0", "2.7.103"])
def test_no_report_frame_repeats_its_predecessor_while_the_arm_moves(  # type: ignore[no-untyped-def]
        make_server, sdk_arm, firmware: str) -> None:
    from xarm_emu.controller.emulator import Emulator

    srv = make_server(emulator=Emulator(6, firmware=firmware))
    readers = {kind: _Reader(srv.ports[kind]) for kind in ("develop", "normal", "rich")}
    for r in readers.values():
        r.start()
    arm: Any = sdk_arm(srv, report_type="devlop")
    try:
        sdk_ready(arm)
        x, y, z, roll, pitch, yaw = arm.position
        assert arm.set_position(x + 80, y, z, roll, pitch, yaw, speed=100, radius=20, wait=False) == 0
        assert arm.set_position(x + 80, y + 80, z, roll, pitch, yaw, speed=100, radius=-1, wait=True) == 0
        time.sleep(0.3)
    finally:
        for r in readers.values():
            r.close()
    develop = [f for _, f in readers["develop"].frames]
    pairs = _moving(develop)
    assert len(pairs) >= 150, len(pairs)  # 1.6 s of motion at 100 Hz
    repeats = [i for i, (a, b) in enumerate(pairs) if a[HEAD:] == b[HEAD:]]
    assert not repeats, f"{len(repeats)} of {len(pairs)} develop frames repeat the one before"
    for kind in ("normal", "rich"):
        slow = _moving([f for _, f in readers[kind].frames])
        assert len(slow) >= 5, (kind, len(slow))
        assert all(a[HEAD:] != b[HEAD:] for a, b in slow), kind
    # the TCP speed the develop frames show never drops below 20 mm/s inside the motion (the corner
    # is blended at radius 20): the speed from the poses of consecutive frames, 10 ms apart
    decode = reports.decode_develop if firmware.startswith("1.") else reports.decode_develop2
    poses = [decode(f).pose for f in develop if f[4] & 0x0F == 1]
    speeds = [math.dist(a[:3], b[:3]) / 0.01 for a, b in zip(poses, poses[1:], strict=False)]
    inner = speeds[15:-15]  # the acceleration at the start and the stop at the end left out
    assert min(inner) >= 20.0, min(inner)


def test_each_develop_frame_shows_the_controller_at_its_deadlines_control_period(  # type: ignore[no-untyped-def]
        make_server, sdk_arm) -> None:
    """The controller's own log of its control periods beside the frames: every develop frame sent
    while the arm moves carries the joints of a period that ends within one period of the frame's
    deadline (the deadlines are the multiples of 10 ms, manual 2.1.6).

    The log holds each period stepped in full (``Controller.step``). The periods between two of
    them, in which only the clock runs (an arm at rest: ``Emulator.next_event``), hold the joints of
    the one before: the first frame after a move command shows state 1 with the joints the arm has
    rested at since its last full period, long before. Such periods never follow a period that
    ended in motion."""
    import numpy as np

    from xarm_emu.controller.core.interface import PERIOD

    srv = make_server()
    emu = srv.emulator
    ctl = emu.controller
    # each period stepped in full: (its number, the joints as the report's fp32, the state after it)
    log: list[tuple[int, tuple[float, ...], int]] = []
    inner = ctl.step

    def logged() -> None:
        inner()
        d = ctl.data
        log.append((d.steps, tuple(float(x) for x in np.float32(d.q)), d.motion_state))

    ctl.step = logged  # type: ignore[method-assign]
    stream = srv.server.reports.streams["develop"]
    made: list[tuple[float, bytes]] = []  # each frame the sender made: its deadline, its bytes
    make = stream.frame

    def recorded(deadline: float) -> bytes | None:
        frame = make(deadline)
        if frame:
            made.append((deadline, frame))
        return frame

    with stream.lock:
        stream.frame = recorded
    reader = _Reader(srv.ports["develop"])
    reader.start()
    arm: Any = sdk_arm(srv, report_type="devlop")
    try:
        sdk_ready(arm)
        x, y, z, roll, pitch, yaw = arm.position
        assert arm.set_position(x + 60, y + 40, z - 30, roll, pitch, yaw, speed=120, wait=True) == 0
        time.sleep(0.1)
    finally:
        reader.close()
    clock = srv.server.clock
    offset = srv.call(lambda: ctl.data.steps - clock.steps)  # controller periods before the clock's
    with srv.server.lock:  # the log as far as the controller has run
        stepped, last = list(log), ctl.data.steps
    periods: dict[tuple[float, ...], list[int]] = {}  # joints -> the periods that ended with them
    for (k, key, state), following in zip(stepped, [e[0] for e in stepped[1:]] + [last + 1],
                                          strict=True):
        assert following == k + 1 or state != 1, (k, following)  # only the clock ran: never in motion
        periods.setdefault(key, []).extend(range(k, following))
    to_mono = time.monotonic() - time.perf_counter()
    # The frames read are whole frames the sender made, in its order: a reader that falls behind on a
    # busy machine skips whole frames (``frames_skipped``), so each is found among the frames made.
    frames = [f for _, f in reader.frames]
    deadlines: list[float] = []
    i = 0
    for frame in frames:
        while i < len(made) and made[i][1] != frame:
            i += 1
        assert i < len(made), f"frame {len(deadlines)} read was never made"
        deadlines.append(made[i][0] + to_mono)
        i += 1
    checked = 0
    for frame, deadline in zip(frames, deadlines, strict=True):
        if frame[4] & 0x0F != 1:
            continue
        joints = tuple(float(x) for x in reports.decode_develop(frame).joints[:6])
        steps = periods.get(joints, [])
        ends = [clock.wall_after(k - offset - clock.steps - 1) for k in steps]  # wall time each ended
        assert any(abs(e - deadline) <= PERIOD + 1e-4 for e in ends), (deadline, ends[:3])
        checked += 1
    assert checked >= 40, checked


def test_a_frame_whose_deadline_is_two_periods_gone_is_not_sent(make_server) -> None:  # type: ignore[no-untyped-def]
    """The sender comes late and a command has already run the controller two periods past the
    deadline's own period: that deadline's state is gone, so its frame is not sent (counted missed)
    rather than show a later state; one period past, it is still sent."""
    from xarm_emu.controller.core.interface import PERIOD

    core = make_server().server
    time.sleep(0.05)  # a few periods after the start
    with core.lock:  # nothing else runs the controller meanwhile
        core.catch_up()
        end = core.clock.wall_after(-1)  # when the last period run ended (monotonic)
        to_perf = time.perf_counter() - time.monotonic()
        # its own period ended two periods before the last one run (which ended 1.25 periods after
        # the deadline, 8.75 ms before the next deadline): gone
        assert core.report_instant(end - 1.25 * PERIOD + to_perf, 0.01) is False
        # its own period is the one before the last one run: sent
        assert core.report_instant(end - 0.5 * PERIOD + to_perf, 0.01) is True


def test_a_controller_held_back_beyond_one_catch_up_sends_no_earlier_state(make_server) -> None:  # type: ignore[no-untyped-def]
    """The controller is held back (its lock held) for more periods than one catch-up runs
    (``MAX_CATCH_UP``): the develop frame of a deadline it cannot reach is not made (the sender counts
    it missed) rather than show an earlier period's state; the next catch-up reaches the deadline's
    period and that frame is made."""
    from xarm_emu.controller.core.interface import PERIOD
    from xarm_emu.server.core import MAX_CATCH_UP

    speed = 10.0  # one catch-up is 0.1 s of wall time
    core = make_server(speed=speed).server
    stream = core.reports.streams["develop"]
    time.sleep(0.02)
    with core.lock:  # nothing else runs the controller meanwhile
        core.catch_up()
        held = core.clock.steps
        time.sleep(1.5 * MAX_CATCH_UP * PERIOD / speed)  # 1.5 catch-ups due
        deadline = time.perf_counter()
        own = core.clock.steps_at(deadline + time.monotonic() - time.perf_counter())
        assert own > held + MAX_CATCH_UP
        assert stream.frame(deadline) == b""  # not sent: one catch-up left it short of the deadline
        assert core.clock.steps == held + MAX_CATCH_UP
        frame = stream.frame(deadline)
        assert frame and core.clock.steps == own  # the next catch-up reaches the deadline's period
        assert frame == reports.encode_develop(core.emulator.snapshot())  # the state of that period


def test_a_250_hz_servo_stream_is_reported_within_a_degree_20_ms_later(  # type: ignore[no-untyped-def]
        make_server, sdk_arm) -> None:
    """Mode 1 (servo motion, manual register 19 / 29): ``set_servo_angle_j`` at 250 Hz moving joint 1
    at 20 degrees per second; the first develop frame 20 ms or more after each command shows joint 1
    no more than one degree behind that command (a frame that repeated an older state would show it
    further behind)."""
    srv = make_server()
    reader = _Reader(srv.ports["develop"])
    reader.start()
    arm: Any = sdk_arm(srv, report_type="devlop")
    commands: list[tuple[float, float]] = []
    try:
        sdk_ready(arm)
        assert arm.set_mode(1) == 0 and arm.set_state(0) == 0
        time.sleep(0.1)
        start = list(arm.angles[:6])
        t0 = time.monotonic()
        for k in range(250):  # one second
            target = start[0] + 20.0 * k * 0.004
            assert arm.set_servo_angle_j([target, *start[1:]], is_radian=False) == 0
            commands.append((time.monotonic(), target))
            time.sleep(max(0.0, t0 + (k + 1) * 0.004 - time.monotonic()))
        time.sleep(0.1)
    finally:
        reader.close()
    frames = [(t, math.degrees(reports.decode_develop(f).joints[0])) for t, f in reader.frames]
    worst = 0.0
    for sent_at, target in commands[:-10]:
        later = next(j for t, j in frames if t >= sent_at + 0.02)
        worst = max(worst, target - later)  # behind the command (the arm moves on after it)
    assert worst <= 1.0, worst
