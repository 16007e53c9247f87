"""``wait=True`` through the unchanged official SDK on a firmware 2.x box: the SDK waits for the
feedback frame of its command (firmware >= 2.0.102) and returns at its first 50 ms poll after the
frame; it never hangs, because the idle state is 2, never 0."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from xarm_emu.controller.core.interface import PERIOD
from xarm_emu.protocol.feedback import FeedbackType, decode_feedback
from xarm_emu.server.thread import ServerThread
from xarm_emu.testing import running_emulator

FW2 = "2.7.103"
#: The SDK polls the state every 50 ms while it waits.
SDK_POLL = 0.05
#: Scheduling jitter of a loaded test machine (two cores shared by several test runs).
JITTER = 0.015


@pytest.fixture(scope="module")
def fw2() -> Iterator[ServerThread]:
    with running_emulator(firmware=FW2) as st:
        yield st


@pytest.fixture
def arm(fw2: ServerThread, sdk_arm: Callable[..., Any]) -> Any:
    a = sdk_arm(fw2)
    a.motion_enable(True)
    a.set_mode(0)
    a.set_state(0)
    assert a.state == 2
    return a


def _wall_of(st: ServerThread) -> Callable[[float], float]:
    """Controller time -> the monotonic wall time at which the server's clock reaches it."""
    def snapshot() -> tuple[float, int]:
        return st.server.clock.next_wall(), st.emulator.controller.steps

    next_wall, steps = st.call(snapshot)  # type: ignore[misc]
    period, speed = st.server.clock.period, st.server.clock.speed
    return lambda t: next_wall - (steps + 1 - t / period) * period / speed


def _frames(arm: Any) -> list[bytes]:
    """The feedback frames the SDK hands to its feedback callback. The SDK passes on only the types
    the user's own mask asks for, so the mask is set (motion finish and trigger: then the SDK sends
    no register 254 around each command)."""
    got: list[bytes] = []
    assert arm.set_feedback_type(FeedbackType.MOTION_FINISH | FeedbackType.TRIGGER) == 0
    arm.register_feedback_callback(lambda data: got.append(bytes(data)))
    return got


def _settled(got: list[bytes], n: int = 1) -> list[bytes]:
    """``got`` once at least ``n`` frames reached the SDK's callback (it runs asynchronously)."""
    end = time.monotonic() + 2.0
    while len(got) < n and time.monotonic() < end:
        time.sleep(0.01)
    return list(got)


def _latency(fw2: ServerThread, arm: Any, got: list[bytes], call: Callable[[], int]) -> float:
    """Seconds from the finish of the command's task (its feedback frame's controller time) to the
    SDK call's return."""
    got.clear()
    code = call()
    t_return = time.monotonic()
    assert code == 0
    finish = [decode_feedback(f) for f in _settled(got)]
    assert finish and finish[-1].kind in (FeedbackType.MOTION_FINISH, FeedbackType.TRIGGER)
    return t_return - _wall_of(fw2)(finish[-1].time_us / 1e6)


def test_set_position_wait_returns_within_one_poll_of_the_move_end(fw2: ServerThread, arm: Any) -> None:
    got = _frames(arm)
    lat = []
    for x in (260.0, 220.0, 250.0, 230.0, 255.0):
        lat.append(_latency(fw2, arm, got, lambda x=x: arm.set_position(
            x=x, y=0, z=150, roll=180, pitch=0, yaw=0, speed=200, wait=True)))
        assert abs(arm.get_position()[1][0] - x) < 0.1  # the arm is at the target when it returns
    assert all(0.0 <= d for d in lat)
    assert statistics.median(lat) <= SDK_POLL + PERIOD + JITTER
    assert max(lat) < 2 * SDK_POLL + PERIOD + JITTER  # never the polling fallback (several idle polls)


def test_set_servo_angle_and_move_gohome_wait_on_their_frames(fw2: ServerThread, arm: Any) -> None:
    got = _frames(arm)
    lat = [_latency(fw2, arm, got, lambda: arm.set_servo_angle(angle=[10, -10, -10, 0, 20, 0], speed=60,
                                                                 wait=True))]
    assert arm.get_servo_angle()[1][0] == pytest.approx(10.0, abs=0.01)
    lat.append(_latency(fw2, arm, got, lambda: arm.move_gohome(speed=60, wait=True)))
    assert arm.get_servo_angle()[1][:6] == pytest.approx([0.0] * 6, abs=0.01)
    assert all(0.0 <= d < 2 * SDK_POLL + PERIOD + JITTER for d in lat)
    assert min(lat) <= SDK_POLL + PERIOD + JITTER


#: Idle polls after which the SDK's wait gives up on a feedback frame and returns anyway.
SDK_IDLE_POLLS = 10


def test_set_tcp_load_wait_returns_on_its_trigger(fw2: ServerThread, arm: Any) -> None:
    """The SDK returns on the trigger frame, not after its idle polls run out: the call with
    ``wait=True`` takes at most two polls longer than the same call without a wait and one state
    read (the baseline, measured here on this machine's load), far below the ten idle polls."""
    baseline = []
    for _ in range(3):
        t0 = time.monotonic()
        assert arm.set_tcp_load(0.5, [0, 0, 30], wait=False) == 0
        arm.get_state()
        baseline.append(time.monotonic() - t0)
    got = _frames(arm)
    t0 = time.monotonic()
    assert arm.set_tcp_load(0.5, [0, 0, 30], wait=True) == 0
    elapsed = time.monotonic() - t0
    assert elapsed < max(baseline) + 2 * SDK_POLL < SDK_IDLE_POLLS * SDK_POLL, (elapsed, baseline)
    kinds = [(decode_feedback(f).kind, decode_feedback(f).register) for f in _settled(got)]
    assert kinds == [(FeedbackType.TRIGGER, 36)]
    assert fw2.call(lambda: list(fw2.emulator.controller.settings.tcp_load)) == pytest.approx([0.5, 0, 0, 30])


def test_set_tcp_offset_waits_on_register_253(fw2: ServerThread, arm: Any) -> None:
    """The SDK asks 253 for a frame once earlier moves have finished, sleeps 0.5 s, then sends 35."""
    got = _frames(arm)
    arm.set_position(x=240, y=0, z=150, roll=180, pitch=0, yaw=0, speed=100, wait=False)
    t0 = time.monotonic()
    assert arm.set_tcp_offset([0, 0, 20, 0, 0, 0]) == 0
    elapsed = time.monotonic() - t0
    fbs = [decode_feedback(f) for f in _settled(got, 2)]
    assert [f.register for f in fbs] == [21, 253]  # the move's finish, then the check's
    assert fbs[1].time_us >= fbs[0].time_us
    assert 0.5 <= elapsed < 0.5 + (fbs[1].time_us - fbs[0].time_us) / 1e6 + 2.0
    assert fw2.call(lambda: list(fw2.emulator.controller.settings.tcp_offset))[2] == pytest.approx(20.0)
    assert fw2.emulator.controller.executor.cmdnum == 0
    arm.set_tcp_offset([0, 0, 0, 0, 0, 0])


def test_wait_with_the_sdk_default_mask_returns_at_the_target(fw2: ServerThread, arm: Any) -> None:
    """Without a user mask the SDK sets 254 [02] around each move and waits for its frame."""
    arm.set_feedback_type(0)
    for x in (230.0, 260.0):
        t0 = time.monotonic()
        assert arm.set_position(x=x, y=20, z=160, roll=180, pitch=0, yaw=0, speed=300, wait=True) == 0
        assert time.monotonic() - t0 < 1.0
        assert fw2.call(lambda: fw2.emulator.controller.tcp_pose()[0]) == pytest.approx(x, abs=0.05)
        assert fw2.emulator.controller.executor.cmdnum == 0


def test_the_idle_state_is_never_0_so_no_wait_hangs(fw2: ServerThread, arm: Any) -> None:
    assert arm.set_state(0) == 0
    states = {arm.get_state()[1] for _ in range(5)}
    assert states == {2}
    t0 = time.monotonic()
    # a move too short to plan: its finish frame still ends the wait
    pos = arm.get_position()[1]
    assert arm.set_position(*pos, speed=100, wait=True) == 0
    assert time.monotonic() - t0 < 1.0


def test_a_wait_ends_when_the_arm_stops(fw2: ServerThread, arm: Any) -> None:
    arm.set_position(x=200, y=100, z=150, roll=180, pitch=0, yaw=0, speed=50, wait=False)
    fw2.call(lambda: fw2.emulator.inject_estop())
    t0 = time.monotonic()
    arm.set_position(x=200, y=-100, z=150, roll=180, pitch=0, yaw=0, speed=50, wait=True)
    assert time.monotonic() - t0 < 1.0
    fw2.call(lambda: fw2.emulator.clear_faults())
    arm.clean_error()
    arm.motion_enable(True)
