"""Safety boundary (registers 52, 59; C35) and per-step self-collision stop (registers 77, 78; C22)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import call, joints7, ready
from hypothesis import given, settings
from hypothesis import strategies as st

from xarm_emu.controller.core import safety
from xarm_emu.controller.core.safety import (
    BOUNDARY_TOL,
    C_BOUNDARY,
    C_SELF_COLLISION,
    COLLISION_MARGIN,
    boundary_violation,
    check_path_step,
    first_boundary_crossing,
    tcp_position,
)
from xarm_emu.controller.emulator import Emulator
from xarm_emu.model.collision import self_collision, tool_model
from xarm_emu.model.robots import XARM6, XARM7

# manual register 52 example: x+ 600, x- 200, y+ 500, y- 100, z+ 600, z- 200
BOX = (600.0, 200.0, 500.0, 100.0, 600.0, 200.0)


def test_boundary_violation_faces_inside_and_switch() -> None:
    assert not boundary_violation((400, 300, 400), BOX, True)
    assert not boundary_violation((600, 500, 600), BOX, True)  # corner belongs to the inside
    assert not boundary_violation((200, 100, 200), BOX, True)
    assert boundary_violation((600.001, 300, 400), BOX, True)
    assert boundary_violation((400, 99.9, 400), BOX, True)
    assert boundary_violation((400, 300, 600.5), BOX, True)
    assert not boundary_violation((0, 0, 0), BOX, False)  # register 59 off


def test_first_boundary_crossing_hand_cases() -> None:
    assert first_boundary_crossing((400, 300, 400), (800, 300, 400), BOX) == pytest.approx(0.5)
    assert first_boundary_crossing((400, 300, 400), (400, 300, 100), BOX) == pytest.approx(2 / 3)
    # leaves through y- (t = 0.25) before x+ (t = 0.5)
    assert first_boundary_crossing((400, 300, 400), (800, -500, 400), BOX) == pytest.approx(0.25)
    assert first_boundary_crossing((400, 300, 400), (500, 400, 500), BOX) is None
    assert first_boundary_crossing((400, 300, 400), (600, 300, 400), BOX) is None  # ends on the face
    assert first_boundary_crossing((700, 300, 400), (400, 300, 400), BOX) == 0.0  # starts outside


def test_step_off_switches_returns_none() -> None:
    q0, q1 = np.zeros(6), np.radians((0, 0, 30, 0, 0, 0))
    assert check_path_step(XARM6, q0, q1, boundary=BOX, boundary_on=False) is None
    assert check_path_step(XARM6, q0, q1, self_collision_on=False) is None


def test_boundary_stop_lies_on_the_boundary() -> None:
    boundary = (400.0, -400.0, 400.0, -400.0, 600.0, 90.0)
    q0, q1 = np.zeros(6), np.array([0.0, 0.3, -0.3, 0.0, 0.0, 0.0])
    assert tcp_position(XARM6, q1)[2] < 90.0
    stop = check_path_step(XARM6, q0, q1, boundary=boundary, boundary_on=True)
    assert stop is not None and stop.code == C_BOUNDARY
    assert 0.0 < stop.fraction < 1.0
    assert np.allclose(stop.q_stop, q0 + stop.fraction * (q1 - q0))
    z = tcp_position(XARM6, stop.q_stop)[2]
    assert 90.0 <= z <= 90.0 + BOUNDARY_TOL
    assert check_path_step(XARM6, q0, q0 + 0.5 * (q1 - q0), boundary=boundary, boundary_on=True) is None


def test_boundary_uses_the_tcp_offset() -> None:
    boundary = (1000.0, -1000.0, 1000.0, -1000.0, 1000.0, 50.0)
    q = np.zeros(6)
    assert check_path_step(XARM6, q, q, boundary=boundary, boundary_on=True) is None
    stop = check_path_step(XARM6, q, q, boundary=boundary, boundary_on=True, tcp_offset=(0, 0, 100, 0, 0, 0))
    assert stop is not None and stop.code == C_BOUNDARY and stop.fraction == 0.0


def test_self_collision_step_stops_before_contact() -> None:
    q0, q1 = np.zeros(6), np.radians((0, 0, 10, 0, 0, 0))
    stop = check_path_step(XARM6, q0, q1, self_collision_on=True)
    assert stop is not None and stop.code == C_SELF_COLLISION
    hit, dist, _ = self_collision(XARM6, stop.q_stop)
    assert not hit and COLLISION_MARGIN <= dist < COLLISION_MARGIN + 0.05
    assert check_path_step(XARM6, q0, np.radians((0, 0, 2, 0, 0, 0)), self_collision_on=True) is None


def test_tool_model_changes_the_step_result() -> None:
    q0 = np.radians((0, -100, -10, 0, 70, 0))
    q1 = np.radians((0, -100, -10, 0, 110, 0))
    assert check_path_step(XARM6, q0, q1, self_collision_on=True) is None
    stop = check_path_step(XARM6, q0, q1, tool_model(21, [40.0, 250.0]), self_collision_on=True)
    assert stop is not None and stop.code == C_SELF_COLLISION and stop.fraction < 1.0


def test_inside_margin_may_only_move_apart() -> None:
    near = np.radians((0, 0, 4.5, 0, 0, 0))
    d = self_collision(XARM6, near)[1]
    assert 0.0 < d < 5.0
    margin = d + 1.0
    out = check_path_step(XARM6, near, np.radians((0, 0, 3, 0, 0, 0)), self_collision_on=True, margin=margin)
    assert out is None
    q_deeper = np.radians((0, 0, 5, 0, 0, 0))
    deeper = check_path_step(XARM6, near, q_deeper, self_collision_on=True, margin=margin)
    assert deeper is not None and deeper.fraction == 0.0 and np.allclose(deeper.q_stop, near)


def test_earliest_stop_wins() -> None:
    q0, q1 = np.zeros(6), np.radians((0, 0, 10, 0, 0, 0))
    z_min = tcp_position(XARM6, q1)[2] + 50.0  # only the end of the step crosses the boundary
    boundary = (1000.0, -1000.0, 1000.0, -1000.0, 1000.0, min(z_min, 111.0))
    stop = check_path_step(XARM6, q0, q1, self_collision_on=True, boundary=boundary, boundary_on=True)
    assert stop is not None
    both = [check_path_step(XARM6, q0, q1, self_collision_on=True),
            check_path_step(XARM6, q0, q1, boundary=boundary, boundary_on=True)]
    assert stop.fraction == min(s.fraction for s in both if s is not None)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6), st.floats(0.05, 0.3))
def test_boundary_stop_never_outside(direction, scale) -> None:
    boundary = (450.0, 0.0, 150.0, -150.0, 400.0, 60.0)
    q0 = np.zeros(6)
    q1 = np.clip(q0 + scale * np.array(direction), XARM6.lower, XARM6.upper)
    stop = check_path_step(XARM6, q0, q1, boundary=boundary, boundary_on=True)
    q_end = q1 if stop is None else stop.q_stop
    p = tcp_position(XARM6, q_end)
    assert not boundary_violation(p, boundary, True)
    if stop is not None:
        excess = max(p[0] - 450, -p[0], p[1] - 150, -150 - p[1], p[2] - 400, 60 - p[2])
        assert excess >= -BOUNDARY_TOL


def test_xarm7_step() -> None:
    q0, q1 = np.zeros(7), np.radians((0, 0, 0, 0, 0, 90, 0))
    stop = check_path_step(XARM7, q0, q1, self_collision_on=True)
    assert stop is not None and stop.code == C_SELF_COLLISION
    assert self_collision(XARM7, stop.q_stop)[1] >= COLLISION_MARGIN


def test_collision_thresholds_fall_as_the_sensitivity_rises() -> None:
    """Register 37 (manual 1.5): the higher the level, the smaller the torque it detects; 0 is off."""
    thresholds = [safety.COLLISION_THRESHOLDS[level] for level in range(1, 6)]
    assert thresholds == sorted(thresholds, reverse=True) and len(set(thresholds)) == 5
    for level, limit in safety.COLLISION_THRESHOLDS.items():
        assert safety.collision_detected(level, limit) and safety.collision_detected(level, -limit)
        assert not safety.collision_detected(level, 0.99 * limit)
    assert not safety.collision_detected(0, 1e6)


def test_injected_collision_stops_a_moving_arm_with_c31() -> None:
    emu = Emulator(7)
    ready(emu)
    call(emu, 37, sensitivity=5)
    call(emu, 12, state=0)  # 37 is a system reset
    call(emu, 23, joints=joints7(1.0), speed=1.0, acc=10.0, mvtime=0.0)
    call(emu, 23, joints=joints7(0.0), speed=1.0, acc=10.0, mvtime=0.0)
    emu.advance(0.3)
    assert emu.controller.state == 1
    with pytest.raises(ValueError, match="joint 8"):
        emu.inject_collision(8, 50.0)
    assert not emu.inject_collision(4, 9.0)
    assert emu.inject_collision(4, 10.0)
    held = emu.joints.copy()
    emu.step(1)
    assert emu.controller.error_code == 31 and emu.controller.state == 4
    assert emu.controller.executor.cmdnum == 0
    emu.advance(0.5)
    np.testing.assert_allclose(emu.joints, held, atol=0.02)  # stopped within one control period
    assert not emu.inject_collision(4, 50.0)  # an arm already in error detects nothing new
    call(emu, 11, joint=8, enable=0)
    call(emu, 16)
    assert not emu.inject_collision(4, 50.0)  # disabled joints: nothing to detect with
