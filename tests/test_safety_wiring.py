"""Safety features through the controller (manual chapter 3): the arm stops on the safety boundary
with C35 and before self-contact with C22; over random command sequences the joints never leave their
limits and the TCP never leaves an enabled boundary."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import call, joints7, ready
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xarm_emu.controller.emulator import Emulator
from xarm_emu.model import collision
from xarm_emu.model import kinematics as kin

BOUNDARY = (400, -400, 400, -400, 500, 50)  # x max, x min, y max, y min, z max, z min (mm)


def tcp_xyz(emu: Emulator) -> np.ndarray:
    return kin.fk(emu.model, emu.controller.q)[:3, 3]


def excess(p: np.ndarray, b: tuple[int, ...] = BOUNDARY) -> float:
    return max(p[0] - b[0], b[1] - p[0], p[1] - b[2], b[3] - p[1], p[2] - b[4], b[5] - p[2])


@pytest.fixture
def emu() -> Emulator:
    e = Emulator(6)
    ready(e)
    return e


def test_line_through_the_boundary_stops_on_it_with_c35(emu: Emulator) -> None:
    call(emu, 52, boundary=BOUNDARY)
    call(emu, 59, on=1)
    call(emu, 21, pose=(207.0, 0.0, 12.0, math.pi, 0.0, 0.0), speed=100.0, acc=2000.0, mvtime=0.0)
    emu.advance(3.0)
    assert call(emu, 15)[1]["error"] == 35
    assert emu.controller.state == 4
    z = tcp_xyz(emu)[2]
    assert 50.0 - 0.1 <= z <= 50.0 + 0.1  # on the face z min = 50
    # Recovery: clear, enable, boundary off, then the move goes through.
    call(emu, 16)
    call(emu, 11, joint=8, enable=1)
    call(emu, 59, on=0)
    call(emu, 12, state=0)
    call(emu, 21, pose=(207.0, 0.0, 12.0, math.pi, 0.0, 0.0), speed=100.0, acc=2000.0, mvtime=0.0)
    emu.advance(3.0)
    assert call(emu, 15)[1]["error"] == 0
    assert tcp_xyz(emu)[2] == pytest.approx(12.0, abs=0.01)


def test_boundary_off_does_not_stop(emu: Emulator) -> None:
    call(emu, 52, boundary=BOUNDARY)
    call(emu, 21, pose=(207.0, 0.0, 12.0, math.pi, 0.0, 0.0), speed=100.0, acc=2000.0, mvtime=0.0)
    emu.advance(3.0)
    assert call(emu, 15)[1]["error"] == 0


def test_folding_the_arm_stops_before_contact_with_c22(emu: Emulator) -> None:
    call(emu, 77, on=1)
    # Fold the wrist back onto the forearm: J5 towards its upper limit (180 deg).
    call(emu, 23, joints=joints7(0.0, 0.0, 0.0, 0.0, 3.1, 0.0), speed=1.0, acc=10.0, mvtime=0.0)
    emu.advance(8.0)
    assert call(emu, 15)[1]["error"] == 22
    hit, dist, _ = collision.self_collision(emu.model, emu.controller.q)
    assert not hit and dist >= 0.9  # stopped with about the 1 mm margin left
    assert emu.controller.q[4] < 3.1


def test_without_detection_the_same_fold_completes(emu: Emulator) -> None:
    call(emu, 23, joints=joints7(0.0, 0.0, 0.0, 0.0, 3.1, 0.0), speed=1.0, acc=10.0, mvtime=0.0)
    emu.advance(8.0)
    assert call(emu, 15)[1]["error"] == 0


def test_collision_tool_model_changes_the_result(emu: Emulator) -> None:
    q = np.array([0.0, -0.3, -0.2, 0.0, 1.4, 0.0])
    assert not collision.self_collision(emu.model, q)[0]
    state, _ = call(emu, 78, params=(40.0, 400.0), tool_type=21)  # long cylinder tool
    assert state & 0x20 == 0
    assert emu.controller.collision_tool.kind == 21
    state, _ = call(emu, 78, params=(-1.0, 100.0), tool_type=21)
    assert state & 0x20 and call(emu, 15)[1]["warning"] == 12


JOINT_LIMITS_SLACK = 1e-6

command = st.one_of(
    # joint targets as fractions of each joint's range; a few land just beyond the limits
    st.tuples(st.just("joint"), st.lists(st.floats(-1.05, 1.05), min_size=6, max_size=6),
              st.floats(0.5, 3.0)),
    st.tuples(st.just("line"), st.tuples(st.floats(150, 500), st.floats(-350, 350), st.floats(-50, 650)),
              st.floats(50.0, 800.0)),
    st.tuples(st.just("stop"), st.none(), st.none()),
    st.tuples(st.just("wait"), st.floats(0.2, 1.5), st.none()),
)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cmds=st.lists(command, min_size=1, max_size=8), boundary_on=st.booleans(), collide_on=st.booleans())
def test_random_programs_respect_limits_boundary_and_links(cmds: list, boundary_on: bool,
                                                           collide_on: bool) -> None:
    emu = Emulator(6)
    ready(emu)
    b = (450, -450, 300, -300, 550, 0)
    if boundary_on:
        call(emu, 52, boundary=b)
        call(emu, 59, on=1)
    if collide_on:
        call(emu, 77, on=1)
    ready_again(emu)
    lower, upper = emu.model.lower, emu.model.upper

    for kind, a, v in cmds:
        if kind == "joint":
            target = [lo + (f + 1.0) / 2.0 * (hi - lo) for f, lo, hi in zip(a, lower, upper, strict=True)]
            call(emu, 23, joints=joints7(*target), speed=v, acc=10.0, mvtime=0.0)
        elif kind == "line":
            call(emu, 21, pose=(*a, math.pi, 0.0, 0.0), speed=v, acc=3000.0, mvtime=0.0)
        elif kind == "stop":
            call(emu, 12, state=4)
        for _ in range(int((a if kind == "wait" else 0.4) / 0.004)):
            q_before = emu.controller.q.copy()
            emu.step()
            q = emu.controller.q

            assert np.all(q >= lower - JOINT_LIMITS_SLACK) and np.all(q <= upper + JOINT_LIMITS_SLACK)
            if boundary_on and excess(kin.fk(emu.model, q_before)[:3, 3], b) <= 0.0:
                assert excess(tcp_xyz(emu), b) <= 0.1
            if collide_on:
                assert collision.self_collision(emu.model, q)[1] > 0.0
        if emu.controller.error_code or emu.controller.state in (4, 5):
            call(emu, 16)
            ready_again(emu)


def ready_again(emu: Emulator) -> None:
    call(emu, 11, joint=8, enable=1)
    call(emu, 12, state=0)
